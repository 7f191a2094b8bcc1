"""Tool latency and throughput over HTTP on localhost.

Starts ``physmind serve`` on a free loopback port with a temporary data
directory (or uses ``--url``), registers a six-object world (a chain of three
cylinders and a cube, a late sphere hitting the cube, a sphere leaving the
view), then measures:

* latency p50/p99 of sequential requests (one keep-alive connection) for
  check_contact, inspect_world_state and simulate_edit;
* throughput (requests/s) with 16 concurrent clients, bounded in count and time.

With ``--mix``: instead, ``--clients`` concurrent clients (default 64 there)
run the tool mix (check_contact, inspect_world_state, simulate_edit summary
and sampled, round robin) for ``--duration`` seconds while one prober asks
/healthz every 50 ms; reports mix throughput, status counts, transport errors
and /healthz p50/p99/max under that load.

With ``--kill-rounds N``: instead, N rounds of ``--clients`` writers (each
creating worlds and simulate_edit rollouts on its own world) against a
server on one data directory that is killed with SIGKILL after
``--duration`` seconds; then a fresh server on the same directory must
answer every acknowledged world and rollout (0 lost), each rollout document
must decode with the right id and the SQLite file must pass
``PRAGMA integrity_check`` (0 corrupt), and no process of a killed server
may be left after 10 s (orphans).

Usage:  python -m bench.bench_server [--requests 300] [--duration 5] [--clients 16]
        python -m bench.bench_server --mix --clients 64 --duration 30
        python -m bench.bench_server --kill-rounds 3 --clients 16 --duration 10
Prints a Markdown table. Loopback only; nothing leaves the machine.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from urllib.parse import urlparse

from tqdm import tqdm

from bench.proc_tree import descendants, is_alive
from physmind.local_server import stop_process
from world.camera import look_at_camera
from world.io import world_to_dict
from world.types import Body, BodyState, Shape, World

REPO = Path(__file__).resolve().parents[1]



def run_threads(threads: list[threading.Thread]) -> float:
    """Start every thread, wait for all; the wall time in seconds."""
    started = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return time.perf_counter() - started

def six_object_world_document() -> dict:
    cyl, ball = Shape("cylinder", radius=0.2, half_height=0.2), Shape("sphere", radius=0.2)
    bodies = (
        Body(0, cyl, BodyState((-2.0, 0.0, 0.2), (3.0, 0.0, 0.0)), friction=0.1, restitution=0.9, color="red", material="metal"),
        Body(1, cyl, BodyState((-0.8, 0.0, 0.2)), friction=0.1, restitution=0.9, color="blue", material="rubber"),
        Body(2, cyl, BodyState((0.2, 0.0, 0.2)), friction=0.1, restitution=0.9, color="green", material="metal"),
        Body(3, Shape("cube", half_extent=0.2), BodyState((1.2, 0.0, 0.2), yaw=0.3), friction=0.2, restitution=0.9, color="yellow", material="rubber"),
        Body(4, ball, BodyState((1.97, -3.0, 0.2), (0.0, 3.5, 0.0), time=1.0), mass=0.5, friction=0.15, color="purple", material="metal"),
        Body(5, ball, BodyState((-3.0, 2.5, 0.2), (-3.0, 0.5, 0.0)), friction=0.05, color="gray", material="rubber"),
    )
    world = World(bodies=bodies, fps=25.0, observed_frames=128, camera=look_at_camera((0.0, -9.0, 6.0), (0.0, 0.0, 0.0)), id="bench-six")
    return world_to_dict(world)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def start_server(data_dir: str, validate_results: bool = True, workers: int | None = None) -> tuple[subprocess.Popen, str]:
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_")}
    env["PHYSMIND_LOG_LEVEL"] = "WARNING"  # per-request log lines would measure stderr, not the tools
    env["PHYSMIND_VALIDATE_RESULTS"] = "1" if validate_results else "0"
    if workers is not None:
        env["PHYSMIND_WORKERS"] = str(workers)
    process = subprocess.Popen([sys.executable, "-m", "physmind.cli", "serve", "--host", "127.0.0.1", "--port", str(port),
                                "--data-dir", data_dir], cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            status, _ = request(connect(url), "GET", "/healthz")
            if status == 200:
                return process, url
        except OSError:
            time.sleep(0.1)
    process.kill()
    raise RuntimeError("server did not start within 60 s")


def connect(url: str) -> http.client.HTTPConnection:
    parsed = urlparse(url)
    if parsed.hostname not in ("127.0.0.1", "localhost", "::1"):
        raise ValueError(f"--url: loopback only, got {parsed.hostname!r}")
    return http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=60)


def request(conn: http.client.HTTPConnection, method: str, path: str, body: dict | None = None,
            api_key: str | None = None) -> tuple[int, bytes]:
    payload = None if body is None else json.dumps(body).encode()
    headers = {"Content-Type": "application/json"} if payload is not None else {}
    if api_key:
        headers["Authorization"] = f"Bearer {api_key}"
    conn.request(method, path, body=payload, headers=headers)
    response = conn.getresponse()
    return response.status, response.read()


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    index = min(len(ordered) - 1, max(0, round(q / 100 * (len(ordered) - 1))))
    return ordered[index]


def latency(url: str, path: str, body: dict, count: int, label: str) -> dict:
    conn = connect(url)
    request(conn, "POST", path, body)  # warm caches
    samples = []
    for _ in tqdm(range(count), desc=f"latency {label}", leave=False, file=sys.stderr):
        started = time.perf_counter()
        status, _ = request(conn, "POST", path, body)
        samples.append((time.perf_counter() - started) * 1000)
        if status != 200:
            raise RuntimeError(f"{label}: HTTP {status}")
    conn.close()
    return {"p50": percentile(samples, 50), "p99": percentile(samples, 99), "mean": statistics.fmean(samples), "n": count}


def throughput(url: str, path: str, body: dict, clients: int, max_requests: int, duration: float) -> dict:
    lock = threading.Lock()
    done = {"ok": 0, "errors": 0}
    deadline = time.monotonic() + duration

    def worker() -> None:
        conn = connect(url)
        while time.monotonic() < deadline:
            with lock:
                if done["ok"] + done["errors"] >= max_requests:
                    break
            status, _ = request(conn, "POST", path, body)
            with lock:
                done["ok" if status == 200 else "errors"] += 1
        conn.close()

    elapsed = run_threads([threading.Thread(target=worker) for _ in range(clients)])
    return {"rps": done["ok"] / elapsed, "requests": done["ok"], "errors": done["errors"], "seconds": elapsed}


def mix_load(url: str, tools: str, clients: int, duration: float, api_key: str | None = None) -> dict:
    """``clients`` threads on the tool mix for ``duration`` s, /healthz probed every 50 ms meanwhile."""
    mix = [
        ("check_contact", {"object_a": 0, "object_b": 1}),
        ("inspect_world_state", {"frame": 60}),
        ("simulate_edit", {"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "summary"}),
        ("simulate_edit", {"edit_type": "remove_object", "object_id": 1}),
    ]
    lock = threading.Lock()
    statuses: dict[int, int] = {}
    transport_errors = {"count": 0, "first": ""}
    health_ms: list[float] = []
    deadline = time.monotonic() + duration

    def worker(index: int) -> None:
        conn = connect(url)
        step = index
        while time.monotonic() < deadline:
            tool, payload = mix[step % len(mix)]
            step += 1
            try:
                status, _ = request(conn, "POST", f"{tools}/{tool}", payload, api_key)
            except (OSError, http.client.HTTPException) as error:
                with lock:
                    transport_errors["count"] += 1
                    transport_errors["first"] = transport_errors["first"] or repr(error)[:200]
                conn.close()
                conn = connect(url)
                continue
            with lock:
                statuses[status] = statuses.get(status, 0) + 1
        conn.close()

    def prober() -> None:
        conn = connect(url)
        while time.monotonic() < deadline:
            started = time.perf_counter()
            try:
                request(conn, "GET", "/healthz")
                health_ms.append((time.perf_counter() - started) * 1000)
            except (OSError, http.client.HTTPException):
                with lock:
                    transport_errors["count"] += 1
                conn.close()
                conn = connect(url)
            time.sleep(0.05)
        conn.close()

    elapsed = run_threads([threading.Thread(target=worker, args=(i,)) for i in range(clients)] + [threading.Thread(target=prober)])
    ok = statuses.get(200, 0)
    return {"rps": ok / elapsed, "seconds": elapsed, "statuses": dict(sorted(statuses.items())),
            "transport_errors": transport_errors["count"], "first_transport_error": transport_errors["first"],
            "healthz_p50": percentile(health_ms, 50) if health_ms else float("nan"),
            "healthz_p99": percentile(health_ms, 99) if health_ms else float("nan"),
            "healthz_max": max(health_ms) if health_ms else float("nan"), "healthz_n": len(health_ms)}


def kill_rounds(rounds: int, clients: int, duration: float, workers: int | None) -> dict:
    """``rounds`` x (writers for ``duration`` s, then SIGKILL); then every acknowledged write is checked."""
    import sqlite3

    document = six_object_world_document()
    worlds: list[str] = []
    rollouts: list[tuple[str, str]] = []
    lock = threading.Lock()
    orphans = 0
    with tempfile.TemporaryDirectory() as data_dir:
        for round_index in range(rounds):
            process, url = start_server(data_dir, workers=workers)
            stop = threading.Event()

            def writer() -> None:
                try:
                    conn = connect(url)
                    own = None
                    while not stop.is_set():
                        status, body = request(conn, "POST", "/v1/worlds", {"world": document})
                        if status == 201:
                            own = json.loads(body)["world_id"]
                            with lock:
                                worlds.append(own)
                        if own is not None:
                            status, body = request(conn, "POST", f"/v1/worlds/{own}/tools/simulate_edit",
                                                   {"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "summary"})
                            if status == 200:
                                with lock:
                                    rollouts.append((own, json.loads(body)["rollout_id"]))
                except (OSError, http.client.HTTPException):
                    return  # the server was killed mid-request: that write was never acknowledged

            threads = [threading.Thread(target=writer, daemon=True) for _ in range(clients)]
            for thread in threads:
                thread.start()
            try:
                time.sleep(duration)
                processes = descendants(process.pid)
            finally:
                process.kill()  # SIGKILL: no clean-up runs in the server
                process.wait()
            stop.set()
            for thread in threads:
                thread.join()
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and any(is_alive(p) for p in processes):
                time.sleep(0.2)
            orphans += sum(is_alive(p) for p in processes)
            print(f"round {round_index + 1}: killed after {duration:g} s; acknowledged so far: {len(worlds)} worlds, "
                  f"{len(rollouts)} rollouts", file=sys.stderr)
        process, url = start_server(data_dir, workers=workers)
        lost = corrupt = 0
        try:
            conn = connect(url)
            for world_id in worlds:
                status, _ = request(conn, "GET", f"/v1/worlds/{world_id}")
                lost += status == 404
                corrupt += status not in (200, 404)
            for world_id, rollout_id in rollouts:
                status, body = request(conn, "GET", f"/v1/worlds/{world_id}/rollouts/{rollout_id}?detail=full")
                if status == 404:
                    lost += 1
                elif status != 200 or json.loads(body)["rollout"]["id"] != rollout_id:
                    corrupt += 1
        finally:
            stop_process(process)
        with sqlite3.connect(Path(data_dir) / "physmind.sqlite3") as db:
            integrity = db.execute("PRAGMA integrity_check").fetchone()[0]
    return {"worlds": len(worlds), "rollouts": len(rollouts), "lost": lost, "corrupt": corrupt,
            "integrity": integrity, "orphans": orphans}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", help="use a running server (loopback only) instead of starting one")
    parser.add_argument("--requests", type=int, default=300, help="sequential requests per inspection tool (simulate_edit: a third)")
    parser.add_argument("--clients", type=int, default=16)
    parser.add_argument("--duration", type=float, default=5.0, help="seconds per throughput run (upper bound)")
    parser.add_argument("--max-throughput-requests", type=int, default=5000)
    parser.add_argument("--workers", type=int, default=None, help="PHYSMIND_WORKERS of the started server (default: its own)")
    parser.add_argument("--mix", action="store_true", help="run only the mixed-tool load test with a /healthz prober")
    parser.add_argument("--no-validate-results", action="store_true", help="start the server with PHYSMIND_VALIDATE_RESULTS=0")
    parser.add_argument("--kill-rounds", type=int, default=0, help="run only the kill -9 durability test, this many rounds")
    args = parser.parse_args(argv)
    if args.requests < 1 or args.clients < 1 or args.duration <= 0 or args.kill_rounds < 0:
        raise SystemExit("bench_server: --requests, --clients, --duration and --kill-rounds must be positive")
    if args.kill_rounds:
        result = kill_rounds(args.kill_rounds, args.clients, args.duration, args.workers)
        print(f"\nPhysMind tool server, kill -9 under write load: {args.kill_rounds} rounds, {args.clients} writers, "
              f"killed after {args.duration:g} s, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}\n")
        print("| worlds acknowledged | rollouts acknowledged | lost | corrupt | integrity_check | orphan processes |")
        print("|---:|---:|---:|---:|---|---:|")
        print(f"| {result['worlds']} | {result['rollouts']} | {result['lost']} | {result['corrupt']} | "
              f"{result['integrity']} | {result['orphans']} |")
        return 0

    process = None
    tmp = tempfile.TemporaryDirectory()
    try:
        if args.url:
            url = args.url.rstrip("/")
            connect(url)
        else:
            process, url = start_server(tmp.name, not args.no_validate_results, args.workers)
        status, body = request(connect(url), "POST", "/v1/worlds", {"world": six_object_world_document()})
        if status != 201:
            raise RuntimeError(f"creating the world failed: {status} {body[:300]!r}")
        world_id = json.loads(body)["world_id"]
        tools = f"/v1/worlds/{world_id}/tools"
        if args.mix:
            result = mix_load(url, tools, args.clients, args.duration)
            print(f"\nPhysMind tool server, tool mix, {args.clients} clients for {args.duration:g} s, {os.cpu_count()} CPUs, "
                  f"workers {args.workers if args.workers is not None else 'default'}, load average {os.getloadavg()[0]:.1f}\n")
            print("| mix req/s (200) | statuses | transport errors | /healthz p50 ms | /healthz p99 ms | /healthz max ms | probes |")
            print("|---:|---|---:|---:|---:|---:|---:|")
            print(f"| {result['rps']:.1f} | {result['statuses']} | {result['transport_errors']} | {result['healthz_p50']:.1f} | "
                  f"{result['healthz_p99']:.1f} | {result['healthz_max']:.1f} | {result['healthz_n']} |")
            if result["first_transport_error"]:
                print(f"first transport error: {result['first_transport_error']}")
            return 0
        cases = [
            ("check_contact", {"object_a": 0, "object_b": 1}, args.requests),
            ("inspect_world_state", {"frame": 60}, args.requests),
            ("simulate_edit", {"edit_type": "remove_object", "object_id": 1, "trajectory_detail": "summary"}, max(1, args.requests // 3)),
            ("simulate_edit (sampled)", {"edit_type": "remove_object", "object_id": 1}, max(1, args.requests // 3)),
        ]
        rows = []
        for label, payload, count in cases:
            tool = label.split(" ")[0]
            lat = latency(url, f"{tools}/{tool}", payload, count, label)
            thr = throughput(url, f"{tools}/{tool}", payload, args.clients, args.max_throughput_requests, args.duration)
            rows.append((label, lat, thr))
        print(f"\nPhysMind tool server, 6-object world, {os.cpu_count()} CPUs, result validation "
              f"{'off' if args.no_validate_results else 'on'}, loopback HTTP/1.1 keep-alive\n")
        print(f"| tool | p50 ms | p99 ms | mean ms | n | req/s ({args.clients} clients) | requests | errors |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        for label, lat, thr in rows:
            print(f"| {label} | {lat['p50']:.2f} | {lat['p99']:.2f} | {lat['mean']:.2f} | {lat['n']} | "
                  f"{thr['rps']:.0f} | {thr['requests']} | {thr['errors']} |")
    finally:
        if process is not None:
            stop_process(process)
        tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())

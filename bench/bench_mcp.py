"""MCP tools/call latency next to the HTTP API's, over loopback (target: p50 <= 5 ms for check_contact).

Starts `physmind serve` on a free loopback port (and `physmind mcp` for stdio),
registers the six-object world and times sequential calls of one tool:

* HTTP API: ``POST /v1/worlds/{id}/tools/check_contact`` on a keep-alive connection;
* MCP, Streamable HTTP, raw: one JSON-RPC ``tools/call`` POST to ``/mcp`` per call (what any client sends);
* MCP, Streamable HTTP, with the SDK's ``Client`` (adds its own work: output-schema validation, pydantic models);
* MCP, stdio, with the SDK's ``Client``.

    nice -n 10 .venv/bin/python bench/bench_mcp.py [--count 300]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from mcp import Client
from mcp.client.stdio import StdioServerParameters

from bench.bench_server import connect, percentile, request, six_object_world_document, start_server
from physmind.local_server import stop_process

REPO = Path(__file__).resolve().parents[1]
ARGS = {"object_a": 0, "object_b": 1}


def _row(label: str, samples: list[float]) -> str:
    return (f"| {label} | {percentile(samples, 50):.2f} | {percentile(samples, 99):.2f} | "
            f"{statistics.fmean(samples):.2f} | {len(samples)} |")


def http_samples(url: str, world_id: str, count: int) -> list[float]:
    conn = connect(url)
    path = f"/v1/worlds/{world_id}/tools/check_contact"
    request(conn, "POST", path, ARGS)
    samples = []
    for _ in range(count):
        started = time.perf_counter()
        status, _ = request(conn, "POST", path, ARGS)
        samples.append((time.perf_counter() - started) * 1000)
        assert status == 200, status
    return samples


def raw_mcp_samples(url: str, world_id: str, count: int) -> list[float]:
    conn = connect(url)
    body = json.dumps({"jsonrpc": "2.0", "id": 1, "method": "tools/call",
                       "params": {"name": "check_contact", "arguments": {"world_id": world_id, **ARGS}}})
    headers = {"Content-Type": "application/json", "Accept": "application/json, text/event-stream"}
    samples = []
    for index in range(count + 1):
        started = time.perf_counter()
        conn.request("POST", "/mcp", body=body, headers=headers)
        response = conn.getresponse()
        payload = json.loads(response.read())
        if index:  # the first call warms caches
            samples.append((time.perf_counter() - started) * 1000)
        assert response.status == 200 and not payload["result"].get("isError"), payload
    return samples


async def sdk_samples(target: object, world_id: str | None, document: dict | None, count: int) -> list[float]:
    async with Client(target) as client:
        if world_id is None:
            world_id = (await client.call_tool("create_world", {"world": document})).structured_content["world_id"]
        arguments = {"world_id": world_id, **ARGS}
        await client.call_tool("check_contact", arguments)
        samples = []
        for _ in range(count):
            started = time.perf_counter()
            result = await client.call_tool("check_contact", arguments)
            samples.append((time.perf_counter() - started) * 1000)
            assert not result.is_error, result.content
        return samples


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=300, help="calls per transport (default 300)")
    args = parser.parse_args(argv)
    document = six_object_world_document()
    with tempfile.TemporaryDirectory(prefix="bench-mcp-") as tmp:
        process, url = start_server(tmp + "/http", validate_results=True)
        try:
            status, body = request(connect(url), "POST", "/v1/worlds", {"world": document})
            world_id = json.loads(body)["world_id"]
            rows = [_row("HTTP API `POST /v1/worlds/{id}/tools/check_contact`", http_samples(url, world_id, args.count)),
                    _row("MCP Streamable HTTP, raw JSON-RPC `tools/call`", raw_mcp_samples(url, world_id, args.count)),
                    _row("MCP Streamable HTTP, SDK `Client.call_tool`",
                         asyncio.run(sdk_samples(url + "/mcp", world_id, None, args.count)))]
        finally:
            stop_process(process)
        env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_")}
        stdio = StdioServerParameters(command=sys.executable, args=["-m", "physmind.cli", "mcp", "--data-dir", tmp + "/stdio"],
                                      env=env, cwd=str(REPO))
        rows.append(_row("MCP stdio, SDK `Client.call_tool`", asyncio.run(sdk_samples(stdio, None, document, args.count))))
    print("| check_contact over | p50 ms | p99 ms | mean ms | calls |")
    print("|---|---:|---:|---:|---:|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())

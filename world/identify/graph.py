"""Bodies linked by pairs (collisions): the connected groups, one owner for every stage that needs them."""

from __future__ import annotations

from typing import Iterable, Sequence


def connected_components(ids: Iterable[int], pairs: Sequence[tuple[int, int]]) -> list[tuple[int, ...]]:
    """Groups of ids joined by pairs (union-find), each sorted, ordered by their smallest id.

    Every id of ``ids`` and of ``pairs`` is in exactly one group (an id in no pair is alone).
    """
    parent: dict[int, int] = {}

    def root(i: int) -> int:
        parent.setdefault(i, i)
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in ids:
        root(i)
    for a, b in pairs:
        parent[root(a)] = root(b)
    groups: dict[int, list[int]] = {}
    for i in parent:
        groups.setdefault(root(i), []).append(i)
    return sorted((tuple(sorted(g)) for g in groups.values()), key=lambda g: g[0])

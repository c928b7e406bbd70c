"""Stepping order and algebraic loops of a connected system, from its connections and
each FMU's output dependencies (the ModelStructure of its modelDescription.xml).

Components are ordered Gauss-Seidel style: a component steps after those it takes inputs
from. Components that feed each other form a coupled group (a strongly connected
component of the connection graph) that is stepped together and iterated. A coupled group
is an *algebraic loop* when a cycle runs through direct feedthroughs only (an output that
depends on an input at the same instant, like Cart.a on Cart.alpha and Pendulum.alpha on
Pendulum.a); such a loop must be solved at every communication point.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class Wire:
    """An output of one component feeding an input of another."""

    source: str  # component name
    output: str  # variable name
    target: str
    input: str

    def __str__(self) -> str:
        return f"{self.source}.{self.output} -> {self.target}.{self.input}"


def strongly_connected(nodes: Iterable[str], edges: Mapping[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm; the groups come out in reverse topological order."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for successor in sorted(edges.get(node, ())):
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == node:
                    break
            groups.append(sorted(group))

    for node in nodes:
        if node not in index:
            visit(node)
    return groups


def stepping_order(components: Iterable[str], connections: Iterable[Wire]) -> list[list[str]]:
    """Groups of components in the order they step; a group of several is coupled."""
    components = list(components)
    edges: dict[str, set[str]] = {name: set() for name in components}
    for c in connections:
        edges[c.source].add(c.target)
    return list(reversed(strongly_connected(components, edges)))


def algebraic_loops(connections: Iterable[Wire],
                    feedthrough: Mapping[str, Mapping[str, set[str]]]) -> list[list[str]]:
    """Cycles of direct feedthrough, as lists of 'Component.variable' in signal order.

    `feedthrough[component][output]` is the set of that component's inputs the output
    depends on directly (from ModelStructure)."""
    edges: dict[str, set[str]] = {}
    for c in connections:
        edges.setdefault(f"{c.source}.{c.output}", set()).add(f"{c.target}.{c.input}")
    for component, outputs in feedthrough.items():
        for output, inputs in outputs.items():
            for name in inputs:
                edges.setdefault(f"{component}.{name}", set()).add(f"{component}.{output}")
    nodes = sorted(set(edges) | {n for targets in edges.values() for n in targets})
    loops = []
    for group in strongly_connected(nodes, edges):
        if len(group) > 1:
            loops.append(_cycle_order(group, edges))
    return loops


def _cycle_order(group: list[str], edges: Mapping[str, set[str]]) -> list[str]:
    """Walk the group along its edges from its first member, for a readable message."""
    members = set(group)
    path = [group[0]]
    while True:
        following = sorted(edges.get(path[-1], set()) & members - set(path))
        if not following:
            return path
        path.append(following[0])


def tear_of(group: list[str], connections: Iterable[Wire],
            held: Collection[tuple[str, str]] = ()) -> tuple[tuple[str, str], list[str]] | None:
    """A single output of the coupled group whose connections, cut, leave the group's other
    internal connections without a cycle, and the members in the order they then step.

    Why one output: a coupled step is then one scalar equation (the torn signal's end value
    must reproduce itself), which a bracketing root finder solves through the jumps that
    stick-slip events cause (pendfmu/simulator/tear.py); for the rig it is Cart.a, the
    cart's acceleration that the pendulum takes. All internal connections count, not only
    the direct feedthroughs: over a step, the pendulum's end angle depends on the cart's
    acceleration during the step too. Candidates are tried in sorted order; None when no
    single output will do (the master then iterates all internal signals, by plain
    fixed-point iteration, which cycles at stick-slip events).

    `held`: outputs whose consumers take their value at the step's start (a sampled
    controller's), which puts no order on the members. Where no output tears all cycles,
    those through held connections are left out: a controller closing the loop around a
    back-drivable rig (Cart.x -> RigController -> CurrentLoop -> Cart) made a second cycle
    that Cart.a does not cut, and the group was iterated. Tried second, so that a group torn
    before keeps its tear and its results (the self-locking rig's loop, torn at I_mean)."""
    members = set(group)
    internal = [c for c in connections if c.source in members and c.target in members]
    found = _single_tear(group, internal)
    if found is None and held:
        found = _single_tear(group, [c for c in internal if (c.source, c.output) not in held])
    return found


def _single_tear(group: list[str], internal: list[Wire]) -> tuple[tuple[str, str], list[str]] | None:
    """The first output, in sorted order, whose cut leaves `internal` acyclic, and the order."""
    for candidate in sorted({(c.source, c.output) for c in internal}):
        edges = {name: set() for name in group}
        for c in internal:
            if (c.source, c.output) != candidate:
                edges[c.source].add(c.target)
        order = _topological(sorted(group), edges)
        if order is not None:
            return candidate, order
    return None


def _topological(nodes: list[str], edges: Mapping[str, set[str]]) -> list[str] | None:
    """Nodes in an order where every edge points forward (Kahn's algorithm, ties by name);
    None if the edges have a cycle."""
    incoming = {node: 0 for node in nodes}
    for node in nodes:
        for successor in edges[node]:
            incoming[successor] += 1
    ready = sorted(node for node in nodes if incoming[node] == 0)
    order = []
    while ready:
        node = ready.pop(0)
        order.append(node)
        for successor in sorted(edges[node]):
            incoming[successor] -= 1
            if incoming[successor] == 0:
                ready.append(successor)
        ready.sort()
    return order if len(order) == len(nodes) else None

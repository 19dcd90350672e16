"""State sorting with a sorting buffer: lazy online strategies, offline references and the
competitive analysis of seed 001.

Seed 001 (Zachmann, VR lecture, "Der Sorting-Buffer" and "Competitive Analysis") puts a buffer
of ``k`` elements between the application and the graphics card and looks at one state
attribute only (its "colour"; here a material id); the cost of an output order is its number
of colour changes. The lecture follows Räcke, Sohler and Westermann, "Online scheduling for
sorting buffers" (ESA 2002), whose model we simulate:

- The buffer holds the first ``k`` elements not yet sent to the GPU; each step one buffered
  element goes to the GPU and the next input element enters.
- A *lazy* strategy keeps sending the current colour while the buffer holds it. Only when the
  buffer is full and holds no element of the current colour (an overflow) does it choose a
  new colour: the strategy's one decision, and one colour change.

In event form (what :func:`simulate` runs): element ``i`` arrives; if the buffer is full, the
strategy picks a buffered colour ``e`` and every buffered ``e`` element is flushed (``e`` is
now the current colour); then element ``i`` goes straight to the GPU if it has the current
colour (the lecture's "Element direkt an Graphikkarte weiterreichen": the current colour's run
continues), else it is stored. At the end every remaining colour is flushed once. The buffer
never holds the current colour, so every decision and every colour left at the end costs one
change. Cost = colour changes = runs of the output, the first colour included: FIFO (no
buffer) costs the runs of the input, and ``k = 1`` is FIFO for every strategy.

A strategy is *c-competitive* when ``C_online <= c * C_opt + a`` with ``a`` independent of
``k``. Stages: :func:`simulate` (buffer core + one eviction policy) → :func:`optimal_changes`
(exact offline optimum by dynamic programming, small inputs) → :func:`lru_worst_case` (an
input on which LRU's ratio grows as ``sqrt(k)``).
"""

from __future__ import annotations

import heapq
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

ONLINE = ("lru", "bounded-waste", "random-choice", "round-robin")
OFFLINE = ("offline-largest", "offline-furthest", "offline-beam")
STRATEGIES = ("fifo", *ONLINE, "offline", *OFFLINE)

# The exact dynamic program stops (ValueError) when one step holds more states than this.
MAX_DP_STATES = 200_000
# States kept per element by the offline beam search. At 16 it finds the optimum on ~99 % of
# random 50-draw streams of 3-5 colours (k <= 6) at 20-30 µs per draw; with many colours
# (tens) it is slower (100-400 µs per draw) and the greedy rules usually beat it.
BEAM_WIDTH = 16


@dataclass(frozen=True)
class SortResult:
    """One stream through a sorting buffer.

    Attributes
    ----------
    strategy : str
        One of :data:`STRATEGIES` (``"offline"``: the best of the offline rules).
    k : int
        Buffer size, elements.
    changes : int
        Colour (state) changes of the output: its number of runs.
    decisions : int
        Overflows at which the strategy chose a colour (each one a change).
    order : (n,) int64
        The output: indices into the input stream, in the order sent to the GPU.
    """

    strategy: str
    k: int
    changes: int
    decisions: int
    order: np.ndarray


def _colours(colours) -> np.ndarray:
    """(n,) int64 from any 1-D integer sequence; ValueError quoting what was received."""
    c = np.asarray(colours)
    if c.ndim != 1:
        raise ValueError(f"colours must be a 1-D sequence, got shape {c.shape}")
    if c.size and not np.issubdtype(c.dtype, np.integer):
        raise ValueError(f"colours must be integers (material ids), got dtype {c.dtype}")
    return c.astype(np.int64, copy=False)


def _check_k(k) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"buffer size k must be a positive integer, got {k!r}")
    return int(k)


def colour_changes(colours) -> int:
    """Colour changes of a stream sent in the given order: its number of runs.

    Parameters
    ----------
    colours : (n,) int
        Colour (material id) per element, in output order.
    """
    c = _colours(colours)
    return int(c.size > 0) + int(np.count_nonzero(c[1:] != c[:-1]))


def next_arrivals(colours) -> np.ndarray:
    """(n,) int64: index of the next element with the same colour, ``n`` if there is none."""
    c = _colours(colours)
    n = c.size
    order = np.argsort(c, kind="stable")
    nxt = np.full(n, n, np.int64)
    same = c[order[1:]] == c[order[:-1]]
    nxt[order[:-1][same]] = order[1:][same]
    return nxt


# -- eviction policies: what each strategy remembers and which colour it flushes --------------
#
# The core calls ``stored(i, c)`` after element i of colour c entered the buffer, ``choose()``
# at an overflow (the buffer is full and holds no element of the current colour) and
# ``flushed(e, count)`` after colour e left the buffer. ``buf`` is the core's dict
# colour -> list of buffered element indices (read-only for policies).


class _LRU:
    """Per-colour timestamp = when its last element was written into the buffer (the lecture:
    writing an element also refreshes the other buffered elements of its colour); evict the
    colour with the oldest timestamp. An ordered dict of buffered colours: O(1) per step."""

    def __init__(self, k, colours, buf, seed):
        self.recent: OrderedDict[int, None] = OrderedDict()

    def stored(self, i, c):
        recent = self.recent
        if c in recent:
            recent.move_to_end(c)
        else:
            recent[c] = None

    def choose(self):
        return next(iter(self.recent))

    def flushed(self, e, count):
        del self.recent[e]


class _BoundedWaste:
    """Waste counter W(c): at each colour change W(c) += (buffered elements of colour c); evict
    the colour with the largest W, whose counter restarts at 0 (Räcke et al.: the waste counts
    buffer space held since the colour last left the buffer).

    With G the changes so far and S(c) the sum of G at the arrival of c's buffered elements,
    W(c) = n(c) * G - S(c): a line in G whose slope n(c) is c's buffered count. Colours are
    grouped by slope, each group a heap on S (smallest S = largest W within the group); the
    buffered counts are distinct positive integers summing to at most k, so at most
    sqrt(2k) groups are compared per decision and an arrival costs O(log k).
    Ties: the larger count, then the smaller S, then the smaller colour id.
    """

    def __init__(self, k, colours, buf, seed):
        self.G = 0
        self.n: dict[int, int] = {}
        self.S: dict[int, int] = {}
        self.version: dict[int, int] = {}
        self.heaps: dict[int, list] = {}
        self.size: dict[int, int] = {}  # valid entries per slope

    def _leave(self, c, slope):
        left = self.size[slope] - 1
        self.size[slope] = left
        if left == 0:
            del self.size[slope]
            del self.heaps[slope]

    def stored(self, i, c):
        old = self.n.get(c, 0)
        if old:
            self._leave(c, old)
        slope = old + 1
        self.n[c] = slope
        s = self.S.get(c, 0) + self.G
        self.S[c] = s
        v = self.version.get(c, 0) + 1
        self.version[c] = v
        heap = self.heaps.setdefault(slope, [])
        size = self.size.get(slope, 0) + 1
        self.size[slope] = size
        heapq.heappush(heap, (s, c, v))
        if len(heap) > 2 * size + 16:  # drop stale entries so a heap stays O(k)
            version = self.version
            heap[:] = [t for t in heap if version[t[1]] == t[2]]
            heapq.heapify(heap)

    def choose(self):
        best = None
        G, version = self.G, self.version
        for slope, heap in self.heaps.items():
            while version[heap[0][1]] != heap[0][2]:
                heapq.heappop(heap)
            s, c, _ = heap[0]
            key = (slope * G - s, slope, -s, -c)
            if best is None or key > best[0]:
                best = (key, c)
        return best[1]

    def flushed(self, e, count):
        self._leave(e, self.n.pop(e))
        self.S[e] = 0
        self.version[e] += 1
        self.G += 1  # a decision is always a colour change


class _Slots:
    """The buffer as k numbered slots; an element takes the lowest free slot (a heap)."""

    def __init__(self, k, colours, buf, seed):
        self.k = k
        self.slot_colour = [-1] * k
        self.free = list(range(k))
        self.slots: dict[int, list[int]] = {}

    def stored(self, i, c):
        s = heapq.heappop(self.free)
        self.slot_colour[s] = c
        self.slots.setdefault(c, []).append(s)

    def flushed(self, e, count):
        free, slot_colour = self.free, self.slot_colour
        for s in self.slots.pop(e):
            slot_colour[s] = -1
            heapq.heappush(free, s)


class _RandomChoice(_Slots):
    """A uniformly random buffered element (the buffer is full at a decision, so a uniform
    slot), its whole colour evicted: frequent colours are picked more often, which over time
    approximates Bounded-Waste's W (the lecture). Seeded."""

    def __init__(self, k, colours, buf, seed):
        super().__init__(k, colours, buf, seed)
        # at most one decision per element: draw them all at once
        self.draws = np.random.default_rng(seed).integers(0, k, size=len(colours)).tolist()
        self.next = 0

    def choose(self):
        s = self.draws[self.next]
        self.next += 1
        return self.slot_colour[s]


class _RoundRobin(_Slots):
    """Random-Choice with the random slot replaced by a pointer that advances one slot per
    decision (cheaper than good random numbers, the lecture's motivation)."""

    def __init__(self, k, colours, buf, seed):
        super().__init__(k, colours, buf, seed)
        self.pointer = 0

    def choose(self):
        s = self.pointer
        self.pointer = (s + 1) % self.k
        return self.slot_colour[s]


class _Lookahead:
    """Offline rules that read the future through :func:`next_arrivals`.

    ``largest``: first colours that never arrive again (their one run is due anyway, and
    flushing them now frees space), then the colour with most buffered elements, then the
    furthest next arrival. ``furthest`` (Belady-like, as in paging): the colour whose next
    arrival is furthest in the future (never = infinitely far), ties to the larger count.
    Remaining ties: smaller colour id. A colour's key changes only when one of its elements
    arrives, so a heap whose stale entries are skipped by version gives O(log k) per step.
    """

    def __init__(self, k, colours, buf, seed, rule):
        self.nxt = next_arrivals(colours).tolist()
        self.n = len(colours)
        self.buf = buf
        self.largest = rule == "largest"
        self.heap: list = []
        self.version: dict[int, int] = {}

    def stored(self, i, c):
        v = self.version.get(c, 0) + 1
        self.version[c] = v
        count, far = len(self.buf[c]), self.nxt[i]
        key = (-(far == self.n), -count, -far) if self.largest else (-far, -count, 0)
        heap = self.heap
        heapq.heappush(heap, (*key, c, v))
        if len(heap) > 2 * len(self.buf) + 16:  # drop stale entries so the heap stays O(k)
            version = self.version
            heap[:] = [t for t in heap if version[t[3]] == t[4]]
            heapq.heapify(heap)

    def choose(self):
        heap, version = self.heap, self.version
        while version[heap[0][3]] != heap[0][4]:
            heapq.heappop(heap)
        return heap[0][3]

    def flushed(self, e, count):
        self.version[e] += 1


class _Scripted:
    """Replays a list of decisions (found by :func:`_beam_decisions`)."""

    def __init__(self, decisions):
        self.decisions = iter(decisions)

    def stored(self, i, c):
        pass

    def choose(self):
        return next(self.decisions)

    def flushed(self, e, count):
        pass


def _beam_decisions(ids: list[int], k: int, width: int) -> list[int]:
    """Decisions of the best lazy strategy a beam search finds: the exact dynamic program of
    :func:`optimal_changes`, keeping after each element only the ``width`` states with the
    least (cost so far + colours buffered), ties to fewer buffered elements (more free
    space). Exact when no step holds more than ``width`` states; O(n * width) dict work, so
    for streams up to ~1e5 elements."""
    ncol = max(ids) + 1
    # state (counts, current) -> (cost, buffered, colours buffered, decision chain)
    layer: dict = {((0,) * ncol, -1): (0, 0, 0, None)}
    for x in ids:
        new: dict = {}
        for (b, cur), (cost, size, distinct, chain) in layer.items():
            if size == k:  # overflow: every buffered colour is a choice
                for e in range(ncol):
                    be = b[e]
                    if not be:
                        continue
                    nb = list(b)
                    nb[e] = 0
                    if x == e:
                        v = (cost + 1, size - be, distinct - 1, (chain, e))
                    else:
                        v = (cost + 1, size - be + 1, distinct - (nb[x] > 0), (chain, e))
                        nb[x] += 1
                    key = (tuple(nb), e)
                    old = new.get(key)
                    if old is None or v[0] < old[0]:
                        new[key] = v
            else:
                if x == cur:
                    key, v = (b, cur), (cost, size, distinct, chain)
                else:
                    nb = list(b)
                    grew = nb[x] == 0
                    nb[x] += 1
                    key, v = (tuple(nb), cur), (cost, size + 1, distinct + grew, chain)
                old = new.get(key)
                if old is None or v[0] < old[0]:
                    new[key] = v
        if len(new) > width:
            ranked = sorted(new.items(), key=lambda kv: (kv[1][0] + kv[1][2], kv[1][1]))
            new = dict(ranked[:width])
        layer = new
    chain = min(layer.values(), key=lambda v: v[0] + v[2])[3]
    decisions = []
    while chain is not None:
        chain, e = chain
        decisions.append(e)
    return decisions[::-1]


_POLICIES = {
    "lru": _LRU,
    "bounded-waste": _BoundedWaste,
    "random-choice": _RandomChoice,
    "round-robin": _RoundRobin,
}


# -- the buffer ---------------------------------------------------------------------------------


def _run(cols: list[int], k: int, policy) -> tuple[int, int, list[int]]:
    """The lazy buffer of the module docstring; returns (changes, decisions, output order)."""
    buf: dict[int, list[int]] = {}
    policy = policy(buf)
    stored, choose, flushed = policy.stored, policy.choose, policy.flushed
    out: list[int] = []
    size = 0
    current = -1  # colour ids are >= 0
    decisions = 0
    for i, c in enumerate(cols):
        if size == k:  # overflow: the buffer holds no element of the current colour
            current = choose()
            items = buf.pop(current)
            size -= len(items)
            out.extend(items)
            flushed(current, len(items))
            decisions += 1
        if c == current:  # the current colour's run continues: straight to the GPU
            out.append(i)
        else:
            lst = buf.get(c)
            if lst is None:
                buf[c] = [i]
            else:
                lst.append(i)
            size += 1
            stored(i, c)
    # The rest, one colour at a time (none of them is the current colour).
    for items in buf.values():
        out.extend(items)
    return decisions + len(buf), decisions, out


def simulate(
    colours, k: int, strategy: str = "lru", *, seed: int = 0, beam_width: int = BEAM_WIDTH
) -> SortResult:
    """Send a stream through a sorting buffer of ``k`` elements with one strategy.

    Parameters
    ----------
    colours : (n,) int
        Colour (material id) of each element in arrival order; any integers.
    k : int
        Buffer size in elements, >= 1.
    strategy : str
        ``"fifo"`` (no reordering); an online strategy of :data:`ONLINE` (``"lru"``,
        ``"bounded-waste"``, ``"random-choice"``, ``"round-robin"``); an offline one:
        ``"offline-largest"``, ``"offline-furthest"`` (greedy lookahead rules),
        ``"offline-beam"`` (beam search over the exact dynamic program) or ``"offline"``, the
        best of the two rules and, when ``beam_width > 0``, the beam search. Offline
        strategies are upper bounds on the optimum (:func:`optimal_changes` is exact).
    seed : int
        Random-Choice's generator seed.
    beam_width : int
        States kept per element by the beam search (``"offline-beam"``, ``"offline"``).

    Returns
    -------
    SortResult
        ``changes`` is exactly the number of runs of ``colours[order]``.

    Notes
    -----
    Online strategies and offline rules: one pass in Python, O(log k) amortized per element
    (Bounded-Waste: O(sqrt k) per decision), about a microsecond per element. The beam search
    costs O(beam_width) per element (tens of microseconds).
    """
    c = _colours(colours)
    k = _check_k(k)
    if strategy not in STRATEGIES:
        raise ValueError(f"unknown strategy {strategy!r}; available: {', '.join(STRATEGIES)}")
    if isinstance(beam_width, bool) or not isinstance(beam_width, (int, np.integer)):
        raise ValueError(f"beam_width must be an integer, got {beam_width!r}")
    n = c.size
    if strategy == "fifo" or n == 0:
        return SortResult(strategy, k, colour_changes(c), 0, np.arange(n, dtype=np.int64))
    if strategy == "offline":
        names = OFFLINE if beam_width > 0 else OFFLINE[:2]
        runs = [simulate(c, k, s, beam_width=beam_width) for s in names]
        best = min(runs, key=lambda r: r.changes)  # first of equals: the cheaper rules
        return SortResult("offline", k, best.changes, best.decisions, best.order)
    # Compact ids (0..C-1) keep the per-colour dicts small and the -1 sentinel free.
    _, ids = np.unique(c, return_inverse=True)
    ids = ids.reshape(-1)
    if strategy == "offline-beam":
        if beam_width < 1:
            raise ValueError(f"offline-beam needs beam_width >= 1, got {beam_width}")
        decisions = _beam_decisions(ids.tolist(), k, int(beam_width))

        def make(buf):
            return _Scripted(decisions)
    elif strategy.startswith("offline-"):
        rule = strategy.removeprefix("offline-")

        def make(buf):
            return _Lookahead(k, ids, buf, seed, rule)
    else:
        cls = _POLICIES[strategy]

        def make(buf):
            return cls(k, ids, buf, seed)

    changes, decisions, out = _run(ids.tolist(), k, make)
    return SortResult(strategy, k, changes, decisions, np.asarray(out, dtype=np.int64))


# -- the exact offline optimum ------------------------------------------------------------------


def optimal_changes(colours, k: int, *, max_states: int = MAX_DP_STATES) -> int:
    """The fewest colour changes any strategy (online or offline) can reach with a buffer of
    ``k`` elements, by dynamic programming over the lazy strategies.

    Every non-lazy strategy can be turned into a lazy one of equal cost (the lecture), so the
    best lazy strategy is optimal; the tests check this against a search over every output
    order a buffer of ``k`` allows. The state after each element is (buffered count per
    colour, current colour) with its least cost; at an overflow every buffered colour is a
    choice.

    Parameters
    ----------
    colours : (n,) int
    k : int
        Buffer size, elements.
    max_states : int
        Limit on states per step. The state space is at most ``binom(k + C, C) * (C + 1)``
        for ``C`` colours (a few colours and a buffer of tens, or many colours and a buffer
        of a few, stay small); streams of a few hundred elements with ``C <= 5`` and
        ``k <= 16`` take well under a second.

    Raises
    ------
    ValueError
        When a step holds more than ``max_states`` states (use ``simulate(.., "offline")``).
    """
    c = _colours(colours)
    k = _check_k(k)
    if c.size == 0:
        return 0
    _, ids = np.unique(c, return_inverse=True)
    ids = ids.reshape(-1).tolist()
    ncol = max(ids) + 1
    layer: dict[tuple[tuple[int, ...], int], int] = {((0,) * ncol, -1): 0}
    for step, x in enumerate(ids):
        new: dict[tuple[tuple[int, ...], int], int] = {}
        for (b, cur), cost in layer.items():
            if sum(b) == k:  # overflow: try every buffered colour
                for e in range(ncol):
                    if not b[e]:
                        continue
                    nb = list(b)
                    nb[e] = 0
                    if x != e:
                        nb[x] += 1
                    key = (tuple(nb), e)
                    if cost + 1 < new.get(key, math.inf):
                        new[key] = cost + 1
            else:
                if x == cur:
                    key = (b, cur)
                else:
                    nb = list(b)
                    nb[x] += 1
                    key = (tuple(nb), cur)
                if cost < new.get(key, math.inf):
                    new[key] = cost
        if len(new) > max_states:
            raise ValueError(
                f"optimal_changes: {len(new):,} states at element {step} of {len(ids)} "
                f"(k = {k}, {ncol} colours) exceed max_states = {max_states:,}; "
                "use simulate(colours, k, 'offline') for large inputs"
            )
        layer = new
    return min(cost + sum(1 for v in b if v) for (b, _), cost in layer.items())


# -- LRU's worst case -----------------------------------------------------------------------------


@dataclass(frozen=True)
class WorstCase:
    """An input on which an online strategy is far from the optimum.

    Attributes
    ----------
    colours : (n,) int64
        The stream.
    k : int
        The buffer size it is built for.
    m : int
        The construction's parameter.
    online_changes, optimal_changes : int
        The strategy's and the optimum's colour changes, from the construction's analysis
        (the tests check both by simulation and dynamic programming).
    """

    colours: np.ndarray
    k: int
    m: int
    online_changes: int
    optimal_changes: int

    @property
    def ratio(self) -> float:
        """Competitive ratio on this input, online / optimal."""
        return self.online_changes / self.optimal_changes


def lru_worst_case(m: int) -> WorstCase:
    """The lecture's lower-bound input for LRU: ``k = m**2`` (m even),
    ``(x_1 .. x_m y^k x_1 .. x_m z^k)^(m/2)``.

    LRU: in every block the ``x_i`` (written before the block) are the oldest colours, so the
    last ``m`` elements of the block evict them one by one (``m`` changes) and the block is
    flushed when the next round's ``x_1`` arrives: ``m (m + 1)`` changes, as many as FIFO.
    The optimum keeps the ``x_i`` buffered while blocks pass, flushes them in groups between
    blocks and sends every block as one run: ``2 m`` changes (the lecture's "2m
    Farbwechsel"; the tests confirm it by dynamic programming for m = 2, 4). Ratio
    ``(m + 1) / 2 = (sqrt(k) + 1) / 2``: LRU is no better than Omega(sqrt k)-competitive.

    Parameters
    ----------
    m : int
        Even, >= 2. Colours: ``y = 0``, ``z = 1``, ``x_i = i + 1``.
    """
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 2 or m % 2:
        raise ValueError(f"m must be an even integer >= 2, got {m!r}")
    m = int(m)
    return WorstCase(lru_adversary(m, m * m), m * m, m, m * (m + 1), 2 * m)


def lru_adversary(m: int, k: int) -> np.ndarray:
    """(n,) int64: :func:`lru_worst_case`'s stream with blocks of ``k >= m`` elements (for a
    buffer of ``k``, where LRU still pays ``m (m + 1)``); ``m`` even >= 2."""
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 2 or m % 2:
        raise ValueError(f"m must be an even integer >= 2, got {m!r}")
    k = _check_k(k)
    if k < m:
        raise ValueError(f"blocks of k = {k} elements need k >= m = {m}")
    xs = np.arange(2, m + 2, dtype=np.int64)
    rounds = [np.concatenate([xs, np.full(k, r % 2, np.int64)]) for r in range(m)]
    return np.concatenate(rounds)

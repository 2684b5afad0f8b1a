"""Reader of the MIT Lincoln Laboratory Bayesian-network encounter model parameter files.

The format and its meaning follow the reference reader, em_read.m of github.com/Airspace-Encounter-Models/
em-model-manned-bayes (code/matlab/em_read.m; line numbers below are of commit 55bcfd6): sections start with a
`#` line (lines 18-58), a table is the counts of one variable's conditional distribution laid out child-fastest,
then parent configurations with the first parent (in variable order) fastest (array2cells/getdims, lines
191-206; asub2ind.m), and a bin whose edges straddle zero dediscretises to exactly 0 (extract_zero_bins, lines
82-95).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

SECTIONS = ("labels_initial", "G_initial", "r_initial", "N_initial", "labels_transition", "G_transition",
            "r_transition", "N_transition", "boundaries", "resample_rates")


class ModelFileError(ValueError):
    """A parameter file that cannot be read as a Lincoln encounter model (exit 2 on the command line)."""


@dataclass(frozen=True)
class Table:
    """One variable's conditional probability table: counts[bin, parent configuration]."""

    variable: int
    parents: tuple[int, ...]  # indices into the network's variables, in variable order (first varies fastest)
    parent_sizes: tuple[int, ...]
    counts: np.ndarray

    def config_index(self, values: np.ndarray) -> np.ndarray:
        """Parent configuration (0-based column) of each row of values[:, variable] (0-based bins); asub2ind.m."""
        index = np.zeros(values.shape[0], dtype=np.int64)
        stride = 1
        for parent, size in zip(self.parents, self.parent_sizes):
            index += values[:, parent] * stride
            stride *= size
        return index


@dataclass(frozen=True)
class EncounterModel:
    path: str
    labels_initial: tuple[str, ...]
    labels_transition: tuple[str, ...]
    order_initial: tuple[int, ...]
    order_transition: tuple[int, ...]
    initial: tuple[Table, ...]      # one per initial variable
    transition: tuple[Table, ...]   # one per variable at t+1 (indices n_initial.. of the transition network)
    temporal_map: tuple[tuple[int, int], ...]  # (variable at t, the same variable at t+1) in transition indices
    boundaries: tuple[np.ndarray | None, ...]  # bin edges per initial variable; None = categorical ('*')
    zero_bins: tuple[int | None, ...]          # 0-based bin that dediscretises to 0, if any
    resample_rates: np.ndarray

    @property
    def n_initial(self) -> int:
        return len(self.labels_initial)

    @property
    def dynamic_depend(self) -> bool:
        """Whether a variable at t+1 has another variable at t+1 as a parent (dbn_sample.m line 19)."""
        future = {t1 for _, t1 in self.temporal_map}
        return any(p in future for table in self.transition for p in table.parents)

    def variable(self, label: str) -> int:
        """Index of an initial variable by its label, e.g. 'v' or '\\dot h'."""
        try:
            return self.labels_initial.index(label)
        except ValueError:
            raise ModelFileError(f"{self.path}: no variable {label!r} in labels_initial") from None


def _topological(adjacency: np.ndarray, path: str, section: str) -> tuple[int, ...]:
    """Parents before children (bn_sort.m); ties in variable order."""
    n = adjacency.shape[0]
    order: list[int] = []
    remaining = set(range(n))
    while remaining:
        ready = [i for i in sorted(remaining) if not any(adjacency[p, i] for p in remaining)]
        if not ready:
            raise ModelFileError(f"{path}: {section} has a cycle")
        order.extend(ready)
        remaining.difference_update(ready)
    return tuple(order)


def _numbers(text: str, path: str, section: str) -> np.ndarray:
    try:
        return np.array([float(x) for x in text.split()], dtype=float)
    except ValueError as exc:
        raise ModelFileError(f"{path}: section {section}: {exc}") from None


def _tables(adjacency: np.ndarray, sizes: np.ndarray, counts: np.ndarray, variables: range, path: str,
            section: str) -> tuple[Table, ...]:
    tables = []
    index = 0
    for i in variables:
        parents = tuple(int(p) for p in np.flatnonzero(adjacency[:, i]))
        parent_sizes = tuple(int(sizes[p]) for p in parents)
        q = int(np.prod(parent_sizes)) if parents else 1
        r = int(sizes[i])
        block = counts[index:index + r * q]
        if block.size != r * q:
            raise ModelFileError(f"{path}: {section} holds {counts.size} counts, fewer than the tables need")
        tables.append(Table(i, parents, parent_sizes, block.reshape((q, r)).T.copy()))  # child fastest
        index += r * q
    if index != counts.size:
        raise ModelFileError(f"{path}: {section} holds {counts.size} counts, the tables need {index}")
    if (counts < 0).any() or not np.isfinite(counts).all():
        raise ModelFileError(f"{path}: {section} has a negative or non-finite count")
    return tuple(tables)


def read_model(path: str | Path) -> EncounterModel:
    """Parse a parameter file (em_read.m). ModelFileError on anything that does not fit the format."""
    name = str(path)
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{name}: {exc.strerror if isinstance(exc, OSError) else exc}") from None
    sections: dict[str, list[str]] = {}
    current = None
    for line in lines:
        if line.startswith("#"):
            current = line[1:].strip()
            if current not in SECTIONS:
                raise ModelFileError(f"{name}: unknown section {line.strip()!r} (em_read.m knows {', '.join(SECTIONS)})")
            sections[current] = []
        elif current is not None and line.strip():
            sections[current].append(line.strip())
    missing = [s for s in SECTIONS if not sections.get(s)]
    if missing:
        raise ModelFileError(f"{name}: not a Lincoln encounter model parameter file (missing {', '.join(missing)})")

    def labels(section: str) -> tuple[str, ...]:
        return tuple(x.strip().strip('"') for x in sections[section][0].split(","))

    labels_initial, labels_transition = labels("labels_initial"), labels("labels_transition")
    n0, n1 = len(labels_initial), len(labels_transition)

    def matrix(section: str, n: int) -> np.ndarray:
        rows = sections[section][:n]
        m = np.array([_numbers(r, name, section) for r in rows]) if len(rows) == n else None
        if m is None or m.shape != (n, n):
            raise ModelFileError(f"{name}: {section} is not a {n}x{n} matrix")
        return m != 0

    g0, g1 = matrix("G_initial", n0), matrix("G_transition", n1)
    r0, r1 = _numbers(sections["r_initial"][0], name, "r_initial"), _numbers(sections["r_transition"][0], name,
                                                                             "r_transition")
    if r0.size != n0 or r1.size != n1 or (r0 < 1).any() or (r1 < 1).any():
        raise ModelFileError(f"{name}: r_initial/r_transition do not give a bin count per variable")
    initial = _tables(g0, r0, _numbers(sections["N_initial"][0], name, "N_initial"), range(n0), name, "N_initial")
    transition = _tables(g1, r1, _numbers(sections["N_transition"][0], name, "N_transition"), range(n0, n1), name,
                         "N_transition")
    # (t) -> (t+1) pairs by label (extract_temporal_map, em_read.m lines 96-110)
    temporal = []
    for i, label in enumerate(labels_transition):
        if label.endswith("(t)"):
            future = label[:-3] + "(t+1)"
            if future in labels_transition:
                temporal.append((i, labels_transition.index(future)))
    if len(temporal) != n1 - n0:
        raise ModelFileError(f"{name}: labels_transition do not pair every (t+1) variable with its (t)")
    bounds: list[np.ndarray | None] = []
    zero_bins: list[int | None] = []
    for k, text in enumerate(sections["boundaries"][:n0]):
        if text.strip() == "*":
            bounds.append(None)
            zero_bins.append(None)
            continue
        edges = _numbers(text, name, "boundaries")
        if edges.size != r0[k] + 1 or (np.diff(edges) <= 0).any():
            raise ModelFileError(f"{name}: boundaries of {labels_initial[k]!r} are not {int(r0[k]) + 1} rising edges")
        bounds.append(edges)
        straddle = np.flatnonzero((edges[:-1] < 0) & (edges[1:] > 0))
        zero_bins.append(int(straddle[-1]) if straddle.size and edges.size > 2 else None)
    if len(bounds) != n0:
        raise ModelFileError(f"{name}: boundaries has {len(bounds)} lines, expected {n0}")
    rates = _numbers(sections["resample_rates"][0], name, "resample_rates")
    if rates.size != n0 or (rates < 0).any() or (rates > 1).any():
        raise ModelFileError(f"{name}: resample_rates is not one probability per initial variable")
    return EncounterModel(name, labels_initial, labels_transition, _topological(g0, name, "G_initial"),
                          _topological(g1, name, "G_transition"), initial, transition, tuple(temporal),
                          tuple(bounds), tuple(zero_bins), rates)


PACKAGED = Path(__file__).resolve().parent / "models"


def packaged_model(name: str) -> Path:
    """Path of a model file shipped with the package (models/, with its LICENSE)."""
    return PACKAGED / name

"""Sampling a Lincoln encounter model: the initial network, its evolution with the transition network, and the
dediscretisation of bins into values; vectorised over samples with numpy.

What the reference samplers of github.com/Airspace-Encounter-Models/em-model-manned-bayes (code/matlab, commit
55bcfd6) do, and where this follows them:
- a variable's bin is drawn from its table's column for the parents' configuration plus a Dirichlet prior
  (bn_sample.m line 24, select_random.m: the first bin whose cumulative weight reaches u * total); the prior is
  a constant added to every count (bn_dirichlet_prior.m lines 18-22; the model's default is 0,
  @EncounterModel/EncounterModel.m line 45) or 'dbe', 1/(r q) (lines 9-14);
- the transition network is sampled every second (dbn_sample.m). For models whose variables at t+1 do not depend
  on one another (all the uncorrelated models), the reference draws each second from the column chosen by the
  *initial* parents and keeps it for the whole trajectory (dbn_sample.m lines 50-70, 71-87): that is the
  default here, transition="reference". transition="markov" re-reads the parents every second (the general
  branch, dbn_sample.m lines 26-47, which the reference takes when the t+1 variables depend on one another);
- a bin becomes a value uniform inside it, a bin straddling zero becomes exactly 0 (dediscretize.m lines 15-30);
  a categorical variable ('*' boundaries) keeps its 1-based bin index;
- within a bin, the value is redrawn with the variable's resample rate each second (resample_events.m lines
  17-31), and whenever its bin changes (dbn_hierarchical_sample.m lines 33-37).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avionics_eval.encounter_models.model import EncounterModel, ModelFileError, Table

TRANSITIONS = ("reference", "markov")


def prior_for(table: Table, prior: float | str) -> float:
    """The Dirichlet pseudo-count added to every cell of a table (bn_dirichlet_prior.m)."""
    if prior == "dbe":
        return 1.0 / table.counts.size
    value = float(prior)
    if not value >= 0:
        raise ModelFileError(f"Dirichlet prior must be >= 0 or 'dbe', got {prior!r}")
    return value


def draw(table: Table, config: np.ndarray, alpha: float, rng: np.random.Generator) -> np.ndarray:
    """One 0-based bin per row from table column config[row] plus alpha (select_random.m)."""
    cumulative = np.cumsum(table.counts[:, config].T + alpha, axis=1)
    u = rng.random(config.shape[0]) * cumulative[:, -1]
    return np.minimum((cumulative < u[:, None]).sum(axis=1), table.counts.shape[0] - 1)


def dediscretize(model: EncounterModel, variable: int, bins: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Values of 0-based bins of an initial variable (dediscretize.m): uniform in the bin, 0 in a zero bin, the
    1-based index for a categorical variable."""
    edges = model.boundaries[variable]
    if edges is None:
        return bins.astype(float) + 1.0
    low, high = edges[bins], edges[bins + 1]
    values = low + (high - low) * rng.random(bins.shape)
    zero = model.zero_bins[variable]
    if zero is not None:
        values[bins == zero] = 0.0
    return values


@dataclass(frozen=True)
class Samples:
    """n sampled trajectories of the model's variables. initial_*: (n, n_initial); dynamic_*: (n, steps, k) for
    the k variables the transition network evolves (dynamic[i] is initial variable dynamic_variables[i]), at
    t = 0, 1, ... s; t = 0 is the initial sample."""

    initial_bins: np.ndarray
    initial_values: np.ndarray
    dynamic_variables: tuple[int, ...]
    dynamic_bins: np.ndarray
    dynamic_values: np.ndarray
    transition_configs: np.ndarray | None  # (n, k) the columns a "reference" transition drew from, else None


def sample_initial(model: EncounterModel, n: int, rng: np.random.Generator, prior: float | str = 0.0) -> np.ndarray:
    """(n, n_initial) 0-based bins from the initial network (bn_sample.m)."""
    bins = np.zeros((n, model.n_initial), dtype=np.int64)
    for i in model.order_initial:
        table = model.initial[i]
        bins[:, i] = draw(table, table.config_index(bins), prior_for(table, prior), rng)
    return bins


def sample(model: EncounterModel, n: int, steps: int, rng: np.random.Generator, prior: float | str = 0.0,
           transition: str = "reference") -> Samples:
    """n trajectories of `steps` seconds (steps + 1 samples of the dynamic variables)."""
    if transition not in TRANSITIONS:
        raise ModelFileError(f"transition must be one of {', '.join(TRANSITIONS)}, got {transition!r}")
    if n < 0 or steps < 0:
        raise ModelFileError("number of samples and steps must be >= 0")
    n0 = model.n_initial
    initial = sample_initial(model, n, rng, prior)
    now = [t for t, _ in model.temporal_map]          # the (t) variables, = initial variables (same index)
    future = {t1: t for t, t1 in model.temporal_map}  # (t+1) index -> (t) index
    if any(t >= n0 for t in now):
        raise ModelFileError(f"{model.path}: a (t) variable of the transition network is not an initial variable")
    k = len(now)
    dyn_bins = np.zeros((n, steps + 1, k), dtype=np.int16)
    dyn_bins[:, 0] = initial[:, now]
    order = [i for i in model.order_transition if i in future]
    x = np.zeros((n, len(model.labels_transition)), dtype=np.int64)
    x[:, :n0] = initial
    fixed = transition == "reference" and not model.dynamic_depend
    configs = None
    if fixed:
        configs = np.stack([model.transition[i - n0].config_index(x) for i in order], axis=1)
    for t in range(1, steps + 1):
        for col, i in enumerate(order):
            table = model.transition[i - n0]
            config = configs[:, col] if fixed else table.config_index(x)
            x[:, i] = draw(table, config, prior_for(table, prior), rng)
        for i in order:
            x[:, future[i]] = x[:, i]
        dyn_bins[:, t] = x[:, now]
    initial_values = np.zeros((n, n0))
    for v in range(n0):
        initial_values[:, v] = dediscretize(model, v, initial[:, v], rng)
    dyn_values = np.zeros((n, steps + 1, k))
    dyn_values[:, 0] = initial_values[:, now]
    for col, v in enumerate(now):
        rate = model.resample_rates[v]
        for t in range(1, steps + 1):
            bins = dyn_bins[:, t, col].astype(np.int64)
            redraw = (bins != dyn_bins[:, t - 1, col]) | (rng.random(n) < rate)
            dyn_values[:, t, col] = np.where(redraw, dediscretize(model, v, bins, rng), dyn_values[:, t - 1, col])
    return Samples(initial, initial_values, tuple(now), dyn_bins, dyn_values, configs)

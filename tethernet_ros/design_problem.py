"""The tether-net simulator as the optimiser's design problem.

:class:`SimulatorProblem` implements :class:`optimizer.problem.DesignProblem`: the design
vector X = [m_c, L_n, r_n, d_L, V_x, V_y, V_z, d_c] within its target's design bounds
(``DESIGN_BOUNDS``, Table 1, for the Zenit-2; docs/targets.md for the others), the exact
system mass m_a, and the reliability of a design from the Monte Carlo evaluator
(:func:`tethernet_ros.montecarlo.evaluate`) on an
:class:`~tethernet_ros.montecarlo.EpisodeBackend`.  :func:`optimize_design` runs a Case on
it (``tethernet optimize`` calls it).
"""
from __future__ import annotations

from dataclasses import asdict
from collections.abc import Callable, Sequence

import numpy as np

from optimizer.run import run_optimization

from . import machine, montecarlo
from .core.config import ConfigError, SimConfig
from .core.fidelity import FIDELITIES, REFERENCE, at_fidelity
from .core.shapes.catalogue import design_bounds_of
from .core.design import (PUBLISHED_OUTCOMES, REFERENCE_DESIGNS, VARIABLE_NAMES, Design,
                          system_mass)
from .core.noise import NoiseModel

__all__ = ["SimulatorProblem", "optimize_design"]


class SimulatorProblem:
    """Case 1 / Case 2 designs evaluated by simulation (see the module docstring).

    backend: where the episodes run (kept open; the caller closes it); config, noise_model:
    every episode's SimConfig and NoiseModel (defaults: docs/model.md, docs/noise.md).
    """

    variable_names: Sequence[str] = VARIABLE_NAMES
    #: the fidelities it evaluates at (core/fidelity.py), for the run's ``fidelity``
    fidelities: tuple[str, ...] = FIDELITIES

    def __init__(self, backend: montecarlo.EpisodeBackend, config: SimConfig | None = None,
                 noise_model: NoiseModel | None = None):
        self.backend = backend
        self.config = config or SimConfig()
        #: the fidelity of ``config`` (reference: as given)
        self.fidelity = REFERENCE
        self.noise_model = noise_model or NoiseModel()
        bounds = design_bounds_of(self.config.target)      # Table 1 for the Zenit-2
        self.bounds = [tuple(bounds[n]) for n in VARIABLE_NAMES]
        self.horizon = float(self.config.horizon)

    def mass(self, x) -> float:
        """m_a (kg) of design vector ``x`` with the configured thread density."""
        return system_mass(float(x[0]), float(x[1]), float(x[2]), float(self.config.density))

    def evaluate(self, x, n_samples: int, base_seed: int, *, stop=None, results_path=None,
                 label: str = "", progress: Callable[[int, int], None] | None = None
                 ) -> montecarlo.MonteCarloResult:
        """:func:`tethernet_ros.montecarlo.evaluate` of design vector ``x``."""
        def prog(done, total, _result):
            if progress is not None:
                progress(done, total)

        return montecarlo.evaluate(Design.from_vector(x), n_samples, base_seed, self.noise_model,
                                   self.config, self.backend, results_path=results_path,
                                   label=label, progress=prog, stop=stop)

    def at_fidelity(self, name: str) -> SimulatorProblem:
        """The same problem with every episode at fidelity ``name`` (core.fidelity.
        at_fidelity of its config: exploration sets the implicit step to 2 ms, so its
        samples' run keys differ from the reference's); itself for the reference."""
        if name == self.fidelity:
            return self
        if self.fidelity != REFERENCE:
            raise ValueError(f"fidelity {name!r}: this problem is already at {self.fidelity!r}")
        other = SimulatorProblem(self.backend, at_fidelity(self.config, name), self.noise_model)
        other.fidelity = name
        return other

    def design_dict(self, x) -> dict:
        return Design.from_vector(x).to_dict()

    def reference_design(self, name: str) -> np.ndarray | None:
        """X of a docs/model.md §9 reference design (None for an unknown name)."""
        ref = REFERENCE_DESIGNS.get(name)
        return None if ref is None else ref.to_vector()

    def published_outcome(self, name: str) -> dict | None:
        """The source's Table 4 row of a reference design (docs/model.md §11)."""
        po = PUBLISHED_OUTCOMES.get(name)
        return None if po is None else asdict(po)

    def settings(self) -> dict:
        return {"config": self.config.to_dict(), "noise_model": asdict(self.noise_model),
                "model_version": montecarlo.model_version()}

    def describe(self) -> str:
        return self.backend.describe()

    def scenario(self) -> str:
        """The scenario settings that differ from the default (the target's tumble, the
        sensing, the closing policy), e.g. 'tumble: rate_deg_s 2, axis transverse'; ''
        for the default scenario (a target at rest, ideal sensing, the threshold)."""
        parts = []
        for name in ("tumble", "sensing", "policy"):
            value = getattr(self.config, name)
            default = type(value)()
            changed = [f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}"
                       for k, v in vars(value).items() if getattr(default, k) != v]
            if changed:
                parts.append(f"{name}: " + ", ".join(changed))
        return "; ".join(parts)

    def machine_facts(self) -> dict:
        """This machine's facts (:func:`tethernet_ros.machine.machine_facts`), which a run
        directory records."""
        return machine.machine_facts()


def optimize_design(case, *, backend: montecarlo.EpisodeBackend | None = None,
                    config: SimConfig | None = None, noise_model: NoiseModel | None = None,
                    **run_options) -> dict:
    """:func:`optimizer.run.run_optimization` of ``case`` on a :class:`SimulatorProblem`.

    backend: None -> a process pool on all cores, closed at the end (a given backend stays
    open).  run_options: the other arguments of ``run_optimization``: ``settings`` (an
    :class:`optimizer.settings.RunSettings`) or its fields one by one (iterations,
    seed_points, samples, validation_samples, seeds, sequential, ...), run_dir, resume,
    progress, callback.
    Returns the run's summary.
    """
    if config is not None and config.early_call:
        raise ConfigError("config field 'early_call': an optimisation races and validates on "
                          "the settled state of its configuration; leave early_call off (the "
                          "seed points and iterations may use it through a fidelity)")
    own = backend is None
    backend = backend or montecarlo.ProcessPoolBackend()
    try:
        return run_optimization(case, SimulatorProblem(backend, config, noise_model),
                                **run_options)
    finally:
        if own:
            backend.close()

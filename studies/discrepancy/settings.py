"""The knobs of the discrepancy search (:class:`Settings`), each checked at construction.

What each knob does is said beside it; why it has its default (the benchmark cases that set it) is in
docs/discrepancy.md, "Settings and why".
"""

from __future__ import annotations

from dataclasses import dataclass

from geometry import validate
from geometry.errors import InputError
from studies.discrepancy.gap import GapScales

#: Settings fields that are integers: (lowest, highest)
_SETTINGS_INTEGERS = {"n_grid": (2, 1000), "n_grid_dense": (2, 1000), "n_fine": (1, 1000), "brent_maxiter": (1, 10_000),
                      "n_grid_box": (2, 100), "box_levels": (0, 50), "max_rounds": (0, 20), "workers": (1, 256),
                      "polish_nfev": (1, 10_000), "refine_top": (1, 100), "pair_top": (0, 20)}
#: Settings fields that are real numbers: (lowest, highest, must be positive); the command line's ranges
_SETTINGS_NUMBERS = {"min_rel_improvement": (0.0, 0.999, True), "min_abs_improvement": (0.0, 1e6, True),
                     "worse_fraction": (0.0, 1.0, False), "hopeless_units": (0.0, 1e6, False),
                     "placement_margin": (0.0, 1e6, False), "large_gap_units_per_run": (0.0, 1e6, True),
                     "refine_fraction": (0.0, 1.0, False), "joint_fraction": (0.0, 1.0, False),
                     "decisive_fit_improvement": (0.0, 0.999, False), "decisive_abs_improvement": (0.0, 1e6, False),
                     "max_worse_units": (0.0, 1e6, False), "max_bic_increase": (-1e12, 1e12, False),
                     "brent_xatol": (0.0, 0.5, True), "nuisance_range": (0.0, 0.9, True),
                     "nuisance_step": (0.0, 1.0, True), "nuisance_prior_sd": (0.0, 10.0, True),
                     "edge_pull": (0.0, 0.5, False)}
_SETTINGS_OPTIONAL = ("min_abs_improvement",)


@dataclass(frozen=True)
class Settings:
    """Knobs of the search (defaults are what the acceptance tests use; docs/discrepancy.md says why)."""

    scales: GapScales = GapScales()          # what one gap unit is, per kind of evidence
    # -- the decision rule (docs/discrepancy.md, "The decision rule")
    min_rel_improvement: float = 0.3         # the held-out gap must shrink by this fraction ...
    min_abs_improvement: float | None = None  # ... and by this many gap units; None: 1.5 with a Cd nuisance, 3 without
    decisive_fit_improvement: float = 0.05   # a candidate lowering the fit cost by this fraction ...
    decisive_abs_improvement: float = 0.5    # ... has its default held-out floor lowered to this
    max_worse_units: float = 1.0             # no kind of evidence may get worse by more than this ...
    worse_fraction: float = 0.05             # ... nor by more than this fraction of the candidate's whole gain
    max_bic_increase: float = 0.0            # an effect must not raise the fit BIC by more than this
    edge_pull: float = 0.05                  # a fit at its plausible edge is tried this far inside (of the
                                             # range's width); implausible only if that costs (edge.py); 0: off
    # -- the search
    hopeless_units: float = 0.25             # a candidate whose coarse grid gains less than this is not refined
    pair_top: int = 2                        # pairs of this many best candidates (a first round adding nothing)
    refine_top: int = 2                      # refined after the screening: the best this many by coarse gain ...
    refine_fraction: float = 0.2             # ... and any gaining this fraction of the best's
    placement_margin: float = 0.5            # a placed effect moves to one valve when that fits better by this
    validation: bool = True                  # the baseline's V&V 20 table per run
    joint_search: bool = True                # a round adding nothing with a large gap left fits joint candidates
    joint_fraction: float = 0.0              # ... if more than this fraction of the baseline's gap is left
    backward: bool = True                    # the backward step after each addition and at the end
    round_polish: bool = True                # each round's winner refitted jointly with every added effect
    second_start: bool = True                # a candidate decisive on the fit but worse held out fitted again
                                             # with the nuisances' profile from their prior (search._second_start)
    large_gap_units_per_run: float = 2.0     # a gap left above this per run is reported as large
    max_rounds: int = 3                      # most effects added
    # -- the fits
    n_grid: int = 6                          # coarse grid points of a one-parameter search (log bounds)
    n_grid_dense: int = 33                   # the coarse grid of a tight_tolerance effect in joint and pair searches
    n_fine: int = 9                          # fine grid points between the best coarse point's neighbours
    brent_xatol: float = 1e-3                # Brent's tolerance, of the log-bounds range
    brent_maxiter: int = 10
    n_grid_box: int = 5                      # grid points per axis over the plausible box (several parameters) ...
    box_levels: int = 3                      # ... then pattern-search levels around the best
    polish_nfev: int = 5                     # joint least-squares refit: function evaluations per parameter
    holdout: tuple | None = None             # names of held-out runs (default: by condition)
    workers: int = 1
    offset_bounds_s: tuple = (-1e-3, 1e-3)   # the position sensor's time offset [s]
    scale_bounds: tuple = (0.95, 1.05)       # the position sensor's scale factor per valve
    # -- baseline-model errors fitted as nuisances (library effects that are not candidates): fitted on the
    # baseline before round 1, refitted with every candidate and added effect, never named; () switches off
    nuisance_effects: tuple = ("discharge_scale",)
    nuisance_range: float = 0.10             # searched within prior x (1 -+ this)
    nuisance_step: float = 0.05              # forward-difference step of the nuisance profile, of its range
    nuisance_prior_sd: float = 0.05          # Gaussian prior sd, as a fraction of the prior value

    def __post_init__(self):
        """Every field checked at construction (type, range, finite): InputError naming it, before any work."""
        for name, (lo, hi) in _SETTINGS_INTEGERS.items():
            object.__setattr__(self, name, validate.number(getattr(self, name), name, integer=True, bounds=(lo, hi)))
        for name, (lo, hi, positive) in _SETTINGS_NUMBERS.items():
            v = getattr(self, name)
            if v is None and name in _SETTINGS_OPTIONAL:
                continue
            object.__setattr__(self, name, validate.number(v, name, bounds=(lo, hi), positive=positive))
        if not isinstance(self.scales, GapScales):
            raise InputError("scales", f"expected a studies.discrepancy.gap.GapScales, got {self.scales!r}")
        for f in ("position_m", "delivery_frac", "pressure_pa"):
            validate.number(getattr(self.scales, f), f"scales.{f}", positive=True)
        self._check_bounds()
        for name in ("validation", "joint_search", "backward", "round_polish", "second_start"):
            validate.boolean(getattr(self, name), name)
        for name in ("holdout", "nuisance_effects"):
            v = getattr(self, name)
            if v is None and name == "holdout":
                continue
            if isinstance(v, str) or not isinstance(v, (tuple, list)) or \
                    not all(isinstance(x, str) and x.strip() for x in v):
                raise InputError(name, f"expected a tuple of names, got {v!r}")
            object.__setattr__(self, name, tuple(v))

    def _check_bounds(self):
        """The sensor nuisances' (low, high) pairs: two finite numbers in range, low < high."""
        for name, lo, hi in (("offset_bounds_s", -1.0, 1.0), ("scale_bounds", 0.0, 10.0)):
            b = getattr(self, name)
            if not isinstance(b, (tuple, list)) or len(b) != 2:
                raise InputError(name, f"expected (low, high), got {b!r}")
            b = tuple(validate.number(x, f"{name}[{i}]", bounds=(lo, hi), positive=lo == 0.0) for i, x in enumerate(b))
            if not b[0] < b[1]:
                raise InputError(name, f"expected low < high, got {b!r}")
            object.__setattr__(self, name, b)

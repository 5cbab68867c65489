"""One trace type for every time series of the pump: simulated, measured, folded onto crank angle.

A :class:`Trace` holds a time vector (t = 0 at top dead centre), the crank speed and named
signals in SI units; the pump driver writes one (``PumpResult.trace``), the measured-data
reader reads one, and the discrepancy workflow folds both onto one revolution of crank
angle (:meth:`Trace.fold`). Signal names: ``inlet_position``, ``delivery_position`` [m],
``cylinder_pressure``, ``load_pressure`` [Pa], ``inlet_mass_flow``,
``delivery_mass_flow`` [kg/s], ``inlet_velocity``, ``delivery_velocity`` [m/s],
``vapour_volume`` [m^3]. The measured-data reader builds one with :meth:`Trace.measured`;
the discrepancy workflow's model revolution (``studies.discrepancy.gap.CycleTrace``) is one
with its delivery attached.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

UNITS = {"position": "m", "pressure": "Pa", "mass_flow": "kg/s", "velocity": "m/s", "volume": "m^3"}


def unit_of(name: str) -> str:
    """SI unit of a signal name (by its suffix)."""
    for suffix, unit in UNITS.items():
        if name.endswith(suffix):
            return unit
    return "-"


@dataclass(frozen=True)
class Trace:
    """Time series of pump signals (SI units); ``time`` increasing, 0 at TDC.

    ``speed_rpm`` may be None for a measured trace whose run states the speed (crank angles
    then need it: :meth:`fold` and :attr:`crank_angle` raise).
    """

    time: np.ndarray
    speed_rpm: float | None = None
    signals: dict = field(default_factory=dict)

    @classmethod
    def measured(cls, time_s, positions: dict, cylinder_pressure_pa=None, load_pressure_pa=None,
                 speed_rpm: float | None = None) -> "Trace":
        """A trace as the measured-data reader gives it: valve positions {"inlet"/"delivery": [m]},
        optional cylinder and load pressures [Pa]."""
        signals = {f"{valve}_position": np.asarray(x) for valve, x in positions.items()}
        if cylinder_pressure_pa is not None:
            signals["cylinder_pressure"] = np.asarray(cylinder_pressure_pa)
        if load_pressure_pa is not None:
            signals["load_pressure"] = np.asarray(load_pressure_pa)
        return cls(np.asarray(time_s), speed_rpm, signals)

    # the names of the measured-data format (CONTRACT.md trace.csv columns)
    @property
    def time_s(self) -> np.ndarray:
        """Time from TDC [s] (``time``)."""
        return self.time

    @property
    def cylinder_pressure_pa(self) -> np.ndarray | None:
        """Cylinder pressure [Pa, absolute], None when the trace has none."""
        return self.signals.get("cylinder_pressure")

    @property
    def load_pressure_pa(self) -> np.ndarray | None:
        """Load pressure [Pa, absolute], None when the trace has none."""
        return self.signals.get("load_pressure")

    def __getattr__(self, name):
        # signals read as attributes: trace.cylinder_pressure
        sig = self.__dict__.get("signals", {})
        if name in sig:
            return sig[name]
        raise AttributeError(name)

    @property
    def crank_angle(self) -> np.ndarray:
        """Crank angle [rad] from TDC (not wrapped)."""
        if self.speed_rpm is None:
            raise ValueError("the trace has no speed_rpm: crank angles need one")
        return np.asarray(self.time) * self.speed_rpm * 2.0 * np.pi / 60.0

    @property
    def crank_deg(self) -> np.ndarray:
        """Crank angle [deg] within [0, 360)."""
        return np.mod(np.degrees(self.crank_angle), 360.0)

    @property
    def positions(self) -> dict:
        """{"inlet"/"delivery": position [m]} for the valves the trace holds."""
        return {v: self.signals[f"{v}_position"] for v in ("inlet", "delivery") if f"{v}_position" in self.signals}

    def fold(self) -> "Trace":
        """The samples sorted by crank angle within one revolution: ``time`` becomes the time
        after TDC within the revolution (stable order, so repeated revolutions interleave)."""
        if self.speed_rpm is None:
            raise ValueError("the trace has no speed_rpm: folding needs one")
        period = 60.0 / self.speed_rpm
        t = np.mod(np.asarray(self.time, dtype=float), period)
        order = np.argsort(t, kind="stable")
        return Trace(t[order], self.speed_rpm, {k: np.asarray(v)[order] for k, v in self.signals.items()})

    def to_frame(self):
        """pandas DataFrame: ``time_s``, ``crank_deg`` and each signal with its SI unit in the column name."""
        import pandas as pd

        cols = {"time_s": np.asarray(self.time), "crank_deg": self.crank_deg}
        for k, v in self.signals.items():
            cols[f"{k}_{unit_of(k).replace('/', '_per_').replace('^3', '3')}"] = np.asarray(v)
        return pd.DataFrame(cols)

    def plot(self, ax=None, signals=("inlet_position", "delivery_position")):
        """Signals against crank angle [deg] (positions in mm, pressures in MPa); returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 3.5))
        deg = np.degrees(self.crank_angle)
        for name in signals:
            if name not in self.signals:
                continue
            v = np.asarray(self.signals[name])
            unit = unit_of(name)
            scale, shown = (1e3, "mm") if unit == "m" else ((1e-6, "MPa") if unit == "Pa" else (1.0, unit))
            ax.plot(deg, v * scale, label=f"{name.replace('_', ' ')} [{shown}]")
        ax.set_xlabel("crank angle from TDC [deg]")
        ax.set_ylabel(" / ".join(sorted({f"[{('mm' if unit_of(n) == 'm' else 'MPa' if unit_of(n) == 'Pa' else unit_of(n))}]" for n in signals if n in self.signals})))
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)   # off the data
        return ax

"""What really happened in a simulated drive: the answer key the inference is scored against.

Examples
--------
>>> from tyrebayes.simulate.drive import simulate_drive
>>> df, truth = simulate_drive(0, "compact_fwd", "winter", duration_s=20.0, surface="snow",
...                            ambient_c=-5.0)
>>> truth.slip.shape == (len(df), 4)
True
"""

from __future__ import annotations

import equinox as eqx
import numpy as np
import pandas as pd

#: Per-sample truth arrays of shape (n, 4), in wheel order fl, fr, rl, rr.
WHEEL_ARRAYS: tuple[str, ...] = (
    "slip",
    "rho_x",
    "wheel_load_n",
    "wheel_centre_speed_mps",
    "c_x_wheel",
    "tyre_temperature_c",
)
#: Per-sample truth arrays of shape (n,).
SAMPLE_ARRAYS: tuple[str, ...] = (
    "time_s",
    "vx_mps",
    "vy_mps",
    "ax_mps2",
    "ay_mps2",
    "yaw_rate_radps",
    "road_wheel_angle_rad",
    "grade_rad",
    "c_x",
    "slip_driven",
    "rho_x_driven",
    "fx_front_n",
    "fx_rear_n",
    "friction_power_w",
    "long_label",
    "lat_label",
    "force_clipped",
)
#: Scalars and short vectors.
SCALARS: tuple[str, ...] = (
    "c_xr",
    "mu_max",
    "mu_slide_ratio",
    "c_y_per_rad",
    "ambient_c",
    "mounting_pitch_rad",
    "ax_gain",
    "yaw_rate_bias_radps",
    "wheel_speed_step_radps",
    "abs_peak_slip",
)
VECTORS: tuple[str, ...] = (
    "radius_m",
    "radius_error",
    "slip_offset",
    "imu_bias_mps2",
    "fz_static_n",
)


class DriveTruth(eqx.Module):
    """Ground truth of one simulated drive, aligned sample by sample with its stream.

    Scalars
    -------
    c_xr : compensated stiffness at 20 °C [-]. mu_max : peak friction on this surface at the
    static load [-]. mu_slide_ratio, c_y_per_rad : the tyre's other parameters. ambient_c [°C].
    mounting_pitch_rad : IMU mounting pitch [rad] (nose-up +). ax_gain : IMU scale factor on ax
    [-]. yaw_rate_bias_radps [rad/s].
    wheel_speed_step_radps : logged wheel-speed quantisation [rad/s]. abs_peak_slip : slip at the
    peak at static load and mean ABS temperature [-] (NaN without ABS events).

    Vectors (fl, fr, rl, rr unless stated)
    --------------------------------------
    radius_m : true rolling radii [m]; radius_error : R_i/R_nom − 1; slip_offset : the slip a
    pipeline sees at zero true slip when it uses the nominal radius, 1/(1 + ε_i) − 1;
    imu_bias_mps2 : (ax, ay) bias [m/s²]; fz_static_n : static wheel loads [N].

    Per sample
    ----------
    time_s (as in the stream), vx_mps (true V_x of the centre of gravity), vy_mps, ax_mps2 (body
    a_x = dV_x/dt − ψ̇ v_y, no gravity), ay_mps2 (body a_y = V_x ψ̇ + dv_y/dt, no gravity),
    yaw_rate_radps, road_wheel_angle_rad, grade_rad,
    c_x (driven wheels' mean C_x(T) [-]), slip_driven / rho_x_driven (driven axle: mean slip of its
    wheels and F_x/F_z of the axle; both axles for AWD), fx_front_n / fx_rear_n [N],
    friction_power_w (sum over wheels of |F_x V σ|), long_label / lat_label (codes into
    :data:`~tyrebayes.simulate.profiles.LONG_LABELS` / ``LAT_LABELS``), force_clipped (demand
    exceeded 97 % of the peak and was clipped). Per wheel (n, 4): slip (true σ_x against the true
    radius), rho_x (F_x/F_z), wheel_load_n, wheel_centre_speed_mps, c_x_wheel,
    tyre_temperature_c.
    """

    # Static metadata.
    vehicle_name: str = eqx.field(static=True)
    drive: str = eqx.field(static=True)
    surface: str = eqx.field(static=True)
    tyre_model: str = eqx.field(static=True)
    seed: int = eqx.field(static=True)
    # Scalars.
    c_xr: float
    mu_max: float
    mu_slide_ratio: float
    c_y_per_rad: float
    ambient_c: float
    mounting_pitch_rad: float
    ax_gain: float
    yaw_rate_bias_radps: float
    wheel_speed_step_radps: float
    abs_peak_slip: float
    # Vectors.
    radius_m: np.ndarray
    radius_error: np.ndarray
    slip_offset: np.ndarray
    imu_bias_mps2: np.ndarray
    fz_static_n: np.ndarray
    # Per sample.
    time_s: np.ndarray
    vx_mps: np.ndarray
    vy_mps: np.ndarray
    ax_mps2: np.ndarray
    ay_mps2: np.ndarray
    yaw_rate_radps: np.ndarray
    road_wheel_angle_rad: np.ndarray
    grade_rad: np.ndarray
    c_x: np.ndarray
    slip_driven: np.ndarray
    rho_x_driven: np.ndarray
    fx_front_n: np.ndarray
    fx_rear_n: np.ndarray
    friction_power_w: np.ndarray
    long_label: np.ndarray
    lat_label: np.ndarray
    force_clipped: np.ndarray
    slip: np.ndarray
    rho_x: np.ndarray
    wheel_load_n: np.ndarray
    wheel_centre_speed_mps: np.ndarray
    c_x_wheel: np.ndarray
    tyre_temperature_c: np.ndarray

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return len(self.time_s)

    @property
    def abs_mask(self) -> np.ndarray:
        """True during ABS braking."""
        from .profiles import LONG_LABELS

        return self.long_label == LONG_LABELS.index("abs")

    def scalars(self) -> dict:
        """Metadata, scalars and vectors as a JSON-ready dict (no per-sample arrays)."""
        out: dict = {
            "vehicle_name": self.vehicle_name,
            "drive": self.drive,
            "surface": self.surface,
            "tyre_model": self.tyre_model,
            "seed": self.seed,
            "n_samples": self.n_samples,
        }
        for name in SCALARS:
            value = float(getattr(self, name))
            out[name] = value if np.isfinite(value) else None
        for name in VECTORS:
            out[name] = [float(v) for v in np.asarray(getattr(self, name))]
        out["tyre_temperature_mean_c"] = float(np.mean(self.tyre_temperature_c))
        out["c_x_mean"] = float(np.mean(self.c_x))
        out["n_abs_samples"] = int(self.abs_mask.sum())
        out["n_force_clipped"] = int(np.sum(self.force_clipped))
        return out

    def samples(self) -> pd.DataFrame:
        """Per-sample truth as a table (wheel arrays as ``name_fl`` ... ``name_rr``)."""
        cols: dict[str, np.ndarray] = {
            name: np.asarray(getattr(self, name)) for name in SAMPLE_ARRAYS
        }
        for name in WHEEL_ARRAYS:
            arr = np.asarray(getattr(self, name))
            for i, w in enumerate(("fl", "fr", "rl", "rr")):
                cols[f"{name}_{w}"] = arr[:, i]
        return pd.DataFrame(cols)

    @classmethod
    def from_parts(cls, scalars: dict, samples: pd.DataFrame) -> DriveTruth:
        """Rebuild a truth from :meth:`scalars` and :meth:`samples` (as ``write_drive`` wrote)."""
        fields: dict = {
            k: scalars[k] for k in ("vehicle_name", "drive", "surface", "tyre_model", "seed")
        }
        for name in SCALARS:
            value = scalars[name]
            fields[name] = float("nan") if value is None else float(value)
        for name in VECTORS:
            fields[name] = np.asarray(scalars[name], dtype=float)
        for name in SAMPLE_ARRAYS:
            fields[name] = samples[name].to_numpy()
        for name in WHEEL_ARRAYS:
            fields[name] = samples[[f"{name}_{w}" for w in ("fl", "fr", "rl", "rr")]].to_numpy()
        return cls(**fields)

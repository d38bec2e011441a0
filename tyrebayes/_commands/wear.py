"""Wear commands: ``wear-thesis`` and ``predict-wear``.

``tyrebayes wear-thesis [--json]`` reproduces the thesis' Table 6.1 simulation (Sec. 6.2): steady
energy rates, tyre temperatures and relative wear of a soft and a stiff tyre at 7 and 40 °C, with
the heat budget that explains why it fails. ``tyrebayes predict-wear --gamma G [--gamma-sd S]
--c-xr C [--c-xr-sd S] --ambient T [--kappa K] [--speed-kmh V] [--json]`` gives the expected wear
per 1000 km (g per car set and mm on the driven axle) for a mixed driving profile
(:func:`tyrebayes.physics.wear_duty.duty_kernel`, a compact FWD car).
"""

from __future__ import annotations

import argparse

import numpy as np

from .._errors import BadInputError
from ._common import check_ambient, print_json


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "wear-thesis",
        help="reproduce the thesis' tread-wear temperature simulation (Table 6.1)",
        description="Soft (C_xr 29) and stiff (C_xr 60) tyre at 100 km/h, F_z 4865 N, rho_x 0.1, "
        "ambient 7 and 40 °C: energy rates, tyre temperatures, relative wear (Figs. 6.4-6.7).",
    )
    p.add_argument("--soft", type=float, default=29.0, help="C_xr of the soft tyre")
    p.add_argument("--stiff", type=float, default=60.0, help="C_xr of the stiff tyre")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=run_thesis)

    q = subparsers.add_parser(
        "predict-wear",
        help="expected wear per 1000 km for a driving profile and ambient temperature",
        description="Monte Carlo over gamma and C_xr uncertainty; physics from tyrebayes.physics.",
    )
    q.add_argument("--gamma", type=float, required=True, help="abrasability at 20 °C [mm^3/J]")
    q.add_argument("--gamma-sd", type=float, default=0.0, help="its standard deviation")
    q.add_argument("--kappa", type=float, default=0.0, help="temperature sensitivity [1/K]")
    q.add_argument("--c-xr", type=float, required=True, help="compensated stiffness C_xr")
    q.add_argument("--c-xr-sd", type=float, default=0.0, help="its standard deviation")
    q.add_argument("--ambient", type=float, required=True, help="ambient temperature [°C]")
    q.add_argument("--speed-kmh", type=float, default=60.0, help="mean speed [km/h]")
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("--json", action="store_true", help="machine-readable output")
    q.set_defaults(func=run_predict)


def run_thesis(args: argparse.Namespace) -> int:
    if not (args.soft > 0 and args.stiff > 0):
        raise BadInputError(f"expected C_xr > 0, got soft={args.soft}, stiff={args.stiff}")
    from ..physics.wear import thesis_reproduction

    out = thesis_reproduction(args.soft, args.stiff)
    if args.json:
        print_json(out)
        return 0
    for k, c in out["cases"].items():
        print(
            f"{k:10s} T_tyre {c['tyre_temperature_c']:6.2f} °C  C_x {c['c_x']:6.2f}  "
            f"w_x {c['energy_rate_w']:6.2f} W"
        )
    print(f"relative wear difference |I_40 - I_7|/max: {out['relative_wear_difference']}")
    print(
        f"rolling loss {out['rolling_loss_w']:.0f} W per tyre dominates the heat; "
        f"soft wears relatively more in heat: {out['soft_wears_relatively_more_in_heat']}"
    )
    return 0


def run_predict(args: argparse.Namespace) -> int:
    for name in ("gamma", "c_xr", "speed_kmh"):
        if not getattr(args, name) > 0:
            raise BadInputError(
                f"--{name.replace('_', '-')}: expected > 0, got {getattr(args, name)}"
            )
    if args.gamma_sd < 0 or args.c_xr_sd < 0:
        raise BadInputError("--gamma-sd/--c-xr-sd: expected >= 0, got a negative value")
    if not -0.2 <= args.kappa <= 0.2:
        raise BadInputError(f"--kappa: expected a value in [-0.2, 0.2], got {args.kappa}")
    check_ambient(args.ambient)
    import jax

    from .._domain import load_vehicle
    from ..inference.summary import summarize
    from ..physics.thermal import StiffnessTemperature, stiffness_at_temperature
    from ..physics.wear import TreadGeometry, volume_to_mass_g
    from ..physics.wear_duty import DutyProfile, duty_kernel

    profile = DutyProfile(mean_speed_mps=args.speed_kmh / 3.6, dt_s=4.0)
    kernel, grid = duty_kernel(
        jax.random.PRNGKey(args.seed),
        args.ambient,
        1000.0,
        profile,
        load_vehicle("compact_fwd"),
        args.c_xr,
        n_drives=8,
    )
    rng = np.random.default_rng(args.seed)
    n = 2000

    def lognormal(mean, sd):
        s = np.sqrt(np.log1p((sd / mean) ** 2))
        return np.exp(np.log(mean) - s**2 / 2 + s * rng.standard_normal(n))

    gamma, c_xr = lognormal(args.gamma, args.gamma_sd), lognormal(args.c_xr, args.c_xr_sd)
    c_x = np.asarray(stiffness_at_temperature(c_xr[:, None], grid[None, :], StiffnessTemperature()))
    factor = np.exp(args.kappa * (grid - 20.0))[None, :] / c_x
    volume = gamma[:, None] * (factor @ kernel.T)  # (n, axles), per wheel
    geom = TreadGeometry()
    out = {
        "ambient_c": args.ambient,
        "g_per_1000km_car_set": summarize(volume_to_mass_g(2 * volume.sum(axis=1), geom)).to_dict(),
        "mm_per_1000km_driven_axle": summarize(volume[:, 0] / geom.wear_area_mm2).to_dict(),
    }
    if args.json:
        print_json(out)
    else:
        s = out["g_per_1000km_car_set"]
        print(
            f"expected wear at {args.ambient:g} °C: {s['mean']:.1f} g per 1000 km per car set "
            f"(90% HDI {s['hdi_90'][0]:.1f}-{s['hdi_90'][1]:.1f})"
        )
    return 0

"""The report's cornering section: its text and table (figure: :func:`.figures.lateral_curves`)."""

from __future__ import annotations

from .content import Report
from .tables import Table, fmt, post

#: What the cornering section shows, above its figure.
LATERAL_TEXT = (
    "Each axle's lateral force over its static load against its slip angle, with the posterior "
    "median curve and 90 % band. No car measures a slip angle: each point is the steering "
    "equation's measured difference α_f − α_r with the other axle's model slip added back, so "
    "the points scatter about the curve by the model's misfit. Where only steady cornering was "
    "driven, front and rear move together (correlation near +1) and only the understeer "
    "gradient is narrow."
)


def lateral_table(report: Report) -> Table:
    """One row per lateral fit: c_y per axle, understeer gradient, steering ratio, μ_y, flags."""
    header = [
        "drive",
        "c_y front [1/rad]",
        "c_y rear [1/rad]",
        "K [rad/(m/s²)]",
        "steering ratio",
        "μ_y",
        "front/rear corr.",
        "converged",
        "adequate",
    ]
    rows = []
    for lat in report.laterals:
        s = lat.summary
        rows.append(
            [
                lat.name,
                post(s["c_y_front"]),
                post(s["c_y_rear"]),
                post(s["understeer_gradient"]),
                post(s["steering_ratio"], 4) if s["steering_ratio"] else "road-wheel angle",
                post(s["mu_y"]) if s["mu_y"] else "not neared",
                fmt(s["front_rear_correlation"], 2),
                fmt(s["converged"]),
                fmt(s["adequate"]),
            ]
        )
    return header, rows

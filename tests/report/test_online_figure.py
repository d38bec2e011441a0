"""The online trajectory figure draws (PNG) with and without its optional layers."""

import numpy as np

from tyrebayes.report.online_figure import online_trajectory_figure


def test_figure_is_png():
    t = 30.0 * np.arange(1, 21)
    mean = 40 + 5 * np.exp(-t / 200)
    sd = 20 / np.sqrt(t)
    ready = sd / mean < 0.06
    png = online_trajectory_figure(
        t,
        mean,
        mean - 1.645 * sd,
        mean + 1.645 * sd,
        ready,
        alarms_s=np.asarray([300.0]),
        batch={"mean": 40.0, "sd": 1.0, "hdi_90": [38.4, 41.6]},
        truth=41.0,
        baseline=(t, mean - 3, sd / 2),
    )
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert online_trajectory_figure(t, mean, mean - sd, mean + sd, np.zeros(20, bool))[:4] == (
        b"\x89PNG"
    )

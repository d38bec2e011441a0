"""Longitudinal friction work: against a hand computation, and the braking split."""

import numpy as np
import pytest

from tyrebayes.physics.vehicle import GRAVITY_MPS2
from tyrebayes.streams import compute_features
from tyrebayes.streams.longitudinal_work import (
    ENGINE_BRAKE_SHARE,
    _corrected_slip,
    _denoised_force,
    _free_slip_ratios,
    _masked_sums,
    _measured_work,
    _noise_variance,
    _slip_scale,
    _work_terms,
    braking_split,
)
from tyrebayes.streams.wear_evidence import drive_wear_evidence

from .test_wear_evidence import VEHICLE, _drive


@pytest.fixture(scope="module")
def drive():
    return _drive(3)


def test_friction_work_against_a_hand_computation(drive):
    """W_x of the driven axle = Σ F_x V σ_x dt (traction, eq. 4.19a) + Σ ρ² g F_z V dt / Ĉ_x,
    ρ² as ρ(t − k) ρ(t + k) with k one more than the smoothing window, g the brush factor."""
    stream, truth = drive
    feats = compute_features(stream, VEHICLE)
    ev = drive_wear_evidence(stream, VEHICLE, features=feats)
    dt = 1.0 / feats.sample_rate_hz
    c_hat = ev.secant_stiffness
    slip = _corrected_slip(feats, _free_slip_ratios(feats, [0], c_hat), "fwd")
    sigma = slip[:, :2].mean(axis=1)
    fx = braking_split(feats.fx_axle_n, feats.fz_axle_n, VEHICLE)[:, 0]
    fz, v = feats.fz_axle_n[:, 0], feats.vx_mps
    ok = feats.valid & np.isfinite(fx) & np.isfinite(sigma) & ~feats.spin
    pull = ok & (fx > 0)
    hand = np.sum(fx[pull] * v[pull] * sigma[pull]) * dt
    rest = ok & ~(fx > 0)
    rho = fx / fz
    k = int(round(feats.smoothing_s * feats.sample_rate_hz)) + 1
    # ρ̂² less the noise's variance, from second differences over k samples, braking apart
    both = braking_split(feats.fx_axle_n, feats.fz_axle_n, VEHICLE)
    braking = both.sum(axis=1) < 0
    d2 = np.full_like(rho, np.nan)
    d2[k:-k] = (rho[k:-k] - 0.5 * (rho[: -2 * k] + rho[2 * k :])) ** 2
    variance = np.zeros_like(rho)
    for group in (braking, ~braking):
        rows = group & np.isfinite(d2)
        variance[group] = np.median(d2[rows]) / (1.5 * 0.4549364231195724)
    square = rho**2 - variance
    a = np.cbrt(1.0 - np.minimum(np.abs(rho), 0.97))
    kern = square * 3.0 / (1.0 + a + a * a) * fz * np.abs(v)
    hand += np.sum(kern[rest]) * dt / c_hat
    # the package's ratios used the Ĉ_x of its third round, the hand the fourth's
    assert ev.work_x_j[0] == pytest.approx(hand, rel=1e-5)
    # and the secant stiffness is the traction kernel over the measured traction work
    kernel = np.sum(kern[pull]) * dt
    measured = np.sum(fx[pull] * v[pull] * sigma[pull]) * dt
    assert c_hat == pytest.approx(kernel / measured, rel=1e-5)
    # physics: a front-driven car's front tyres do most of the work; the scale is the
    # simulator's within the stated evidence error (benchmarks/results/wear_history.json)
    true = np.sum(
        np.abs(truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps * truth.slip), axis=0
    ) * np.mean(np.diff(truth.time_s))
    assert ev.work_x_j[0] > 5 * ev.work_x_j[1]
    assert 0.5 < ev.work_x_j[0] / true[:2].sum() < 1.5
    assert 0 < ev.work_x_sd_j[0] < 0.2 * ev.work_x_j[0]


@pytest.mark.parametrize("drive_kind", ["fwd", "rwd", "awd"])
def test_measured_work_from_sums_is_the_sum_over_samples(drive, drive_kind):
    """The iteration over radius ratios reads the measured traction work from sums taken once:
    at any ratios it is Σ F_x V σ dt over each axle's traction samples with σ the mean of its
    wheels' corrected slips, as a pass over the samples gives it."""
    stream, _ = drive
    feats = compute_features(stream, VEHICLE)
    dt = 1.0 / feats.sample_rate_hz
    valid = feats.valid & np.isfinite(feats.vx_mps)
    fx = braking_split(feats.fx_axle_n, feats.fz_axle_n, VEHICLE)
    terms = _work_terms(feats, fx, np.array([True, drive_kind == "awd"]), valid, dt)
    sums = _masked_sums(feats, terms, dt)
    rng = np.random.default_rng(4)
    found = []
    for ratios in (np.full(4, np.nan), 1.0 + 0.004 * rng.standard_normal(4)):
        slip = _corrected_slip(feats, ratios, drive_kind)
        sigma = np.column_stack([slip[:, :2].mean(axis=1), slip[:, 2:].mean(axis=1)])
        traction = sums.use & terms.pushing
        by_samples = np.where(traction, terms.power_w * sigma, 0.0).sum(axis=0) * dt
        by_sums = _measured_work(sums, _slip_scale(ratios, drive_kind))
        assert by_sums == pytest.approx(by_samples, rel=1e-9, abs=1e-9)
        found.append(by_samples[0])
    assert found[0] > 0 and found[1] != found[0]  # traction work at nominal radii, then moved


def test_braking_split_puts_engine_drag_on_the_driven_axle():
    weight = VEHICLE.mass_kg * GRAVITY_MPS2
    fz = np.array([[8000.0, 6000.0]] * 3)
    coast = -0.5 * ENGINE_BRAKE_SHARE * weight
    hard = -0.5 * weight
    fx = np.array([[0.7 * coast, 0.3 * coast], [0.7 * hard, 0.3 * hard], [900.0, 0.0]])
    out = braking_split(fx, fz, VEHICLE)
    assert out.sum(axis=1) == pytest.approx(fx.sum(axis=1))  # the total is kept
    assert out[0] == pytest.approx([coast, 0.0])  # coasting: engine drag on the driven front
    engine = -ENGINE_BRAKE_SHARE * weight
    assert out[1, 0] == pytest.approx(engine + (hard - engine) * 8000.0 / 14000.0)
    assert out[2] == pytest.approx(fx[2])  # traction as it was


def test_noise_variance_reads_the_noise_of_a_force_that_steps():
    """White noise on a force that holds still and steps now and then (braking onsets): the
    variance per group within 15 % of the noise's, where the force's steps are up to 30 times
    the noise; ρ̂² less it sums to the true Σ ρ², which the product over ±k does not."""
    rng = np.random.default_rng(1)
    n = 20000
    steps = np.repeat(rng.choice([0.0, -0.1, -0.3], size=n // 100), 100)  # a level per 10 s
    noisy = steps + 0.01 * rng.standard_normal(n)
    groups = steps < 0
    var = _noise_variance(np.column_stack([noisy, 0.5 * noisy]), 3, groups)
    assert var[:, 0] == pytest.approx(1e-4, rel=0.15)
    assert var[:, 1] == pytest.approx(0.25e-4, rel=0.15)
    truth = np.sum(steps**2)
    assert np.sum(noisy**2 - var[:, 0]) == pytest.approx(truth, rel=0.01)
    product = np.sum(noisy[:-6] * noisy[6:])
    assert product < 0.985 * truth


def test_denoised_force_finds_the_true_mean_of_samples_its_noise_chose():
    """Samples chosen by a noisy |ρ̂| < 0.02: their own mean ρ̂ holds the noise that chose
    them; the regression-calibrated force gives their true mean within a third of that error."""
    rng = np.random.default_rng(0)
    n = 20000
    true = np.empty(n)
    true[0] = 0.05
    for t in range(1, n):  # a smooth force (AR(1) over ~3 s at 10 Hz) around ρ = 0.05
        true[t] = 0.05 + 0.97 * (true[t - 1] - 0.05) + 0.01 * rng.standard_normal()
    noisy = true + 0.03 * rng.standard_normal(n)
    chosen = np.abs(noisy) < 0.02
    est = _denoised_force(np.column_stack([noisy, noisy]), 1)[chosen, 0].mean()
    own = noisy[chosen].mean()
    target = true[chosen].mean()
    assert abs(est - target) < abs(own - target) / 3


def test_commute_work_reads_the_simulators_true_work():
    """A 10-minute commute with corners: the evidence's longitudinal work against the
    simulator's Σ |F_x V σ_x| dt."""
    from tyrebayes.simulate.drive import simulate_drive
    from tyrebayes.simulate.wear_history import COMMUTE_PROFILE
    from tyrebayes.streams import validate_stream

    df, truth = simulate_drive(
        3,
        VEHICLE,
        "summer",
        duration_s=600.0,
        sample_rate_hz=10.0,
        profile=COMMUTE_PROFILE,
        ambient_c=15.0,
    )
    ev = drive_wear_evidence(validate_stream(df, VEHICLE), VEHICLE)
    dt = np.diff(truth.time_s, append=truth.time_s[-1])[:, None]
    power = np.abs(truth.rho_x * truth.wheel_load_n * truth.wheel_centre_speed_mps * truth.slip)
    true = np.array([np.sum(power[:, :2] * dt), np.sum(power[:, 2:] * dt)])
    ratio = ev.work_x_j / true
    assert abs(ratio[0] - 1.0) < 0.08, ratio
    assert abs(ratio[1] - 1.0) < 0.2, ratio

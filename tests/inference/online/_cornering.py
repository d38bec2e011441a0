"""Simulated cornering observations for the online lateral estimator's tests."""

from tyrebayes._domain import load_vehicle
from tyrebayes.inference.lateral import cornering_observations
from tyrebayes.simulate.cornering import simulate_cornering
from tyrebayes.streams import validate_stream

DURATION_S = 300.0


def observations(manoeuvre: str, seed: int, duration_s: float = DURATION_S):
    """A simulated drive's cornering observations and its true parameters."""
    vehicle = load_vehicle("compact_fwd")
    frame, truth = simulate_cornering(
        vehicle, manoeuvre=manoeuvre, duration_s=duration_s, seed=seed
    )
    return cornering_observations(validate_stream(frame, vehicle).data, vehicle), truth

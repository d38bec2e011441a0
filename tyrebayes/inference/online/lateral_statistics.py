"""Sufficient statistics of the online lateral estimator: each equation's regressors' moments.

Near zero the batch model's tyre curve (the Magic Formula,
:func:`~tyrebayes.physics.magic_formula.magic_formula_inverse_and_slope`) departs from its
tangent by odd powers, α = (ρ/c_y)(1 + λ ρ² + κλ² ρ⁴ + …) with λ = k₃/μ_y² and κ = k₅/k₃²
(:func:`~tyrebayes.physics.magic_formula.magic_formula_inverse_series`; κ at the curve priors'
medians, where it changes the fifth-order term, itself about 2 % of α at 60 % of the peak, by a
fraction of it). To that order both equations of the batch lateral model
(:mod:`tyrebayes.inference.lateral.model`) have residuals that are *linear* in a vector of
coefficients, and the coefficients are functions of the physical parameters. With u = 1/c_f, v =
1/c_r, the roll gain Γ = 1 + g k_φ, the a_y offset b, the steering-wheel offset δ₀, the steering
ratio i_s and the yaw inertia J_z = f·J₀ (P = J₀/(m g)), the steering equation (δ_sw − δ₀)/i_s −
L r/V_x = α_f − α_r reads

    e_s = z_s · c_s,   z_s = [δ_sw, 1, a_y, ṙ, L r/V_x, ρ̃_f³, ρ̃_r³, ρ̃_f⁵, ρ̃_r⁵],
    c_s = [1/i_s, −δ₀/i_s + (u − v) b/(Γ g), −(u − v)/(Γ g), −f P (u/l_r + v/l_f), −1,
           −λu, λv, −κλ²u, κλ²v],

and the kinematic equation a_y = Γ (V_x r + l_r ṙ − d(V_x α_r)/dt) + b

    e_k = z_k · c_k,
    z_k = [a_y, V_x r + l_r ṙ, 1, d(V_x a_y)/dt, dV_x/dt, d(V_x ṙ)/dt, d(V_x ρ̃_r³)/dt,
           d(V_x ρ̃_r⁵)/dt],
    c_k = [1, −Γ, −b, v/g, −v b/g, −Γ v f P/l_f, Γ v λ, Γ v κλ²].

The curve terms' axle forces ρ̃ are taken at the nuisances' prior medians (no offset, the
median roll gain, the vehicle file's J_z): their error moves terms that are themselves a few
per cent of α by a few per cent of them.

So every sum the estimator needs is a quadratic (or linear) form of the coefficients in
moments of z that do not depend on the parameters: Σe² = cᵀ(Σ z zᵀ)c, the lag-one product
Σ e_t e_(t−1) = cᵀ(Σ z_t z_(t−1)ᵀ)c, and the means of the residuals over the 10 s, 30 s and
60 s batches of the variance inflation (:mod:`.lateral_vif`) from the batches' mean z. A block's
moments are taken once, vectorised over all blocks (:func:`block_moments`); the estimator then
only adds matrices and solves an eight-parameter problem per block (:mod:`.lateral`).

Beyond the series' range, near the curve's peak, the model reads c_y low. The batch fit, with
the whole curve, is the reference the benchmark compares against (``online_lateral.py``).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from ...internal.device_arrays import device_array
from ..lateral.data import G
from ..lateral.model import derivative
from .lateral_blocks import LateralBlocks

#: The shortest batch of the variance inflation's batch means [samples] (10 s at 10 Hz); the
#: others are a block (30 s) and two blocks (60 s), the batch fit's ``INFLATION_BLOCKS``
#: (:mod:`.lateral_vif`).
CHUNK = 100


class EquationMoments(eqx.Module):
    """Moments of one equation's augmented regressors z over its valid samples.

    The leading axes (none, or one per block) index what the sums are over.

    Attributes
    ----------
    count : Float[Array, "..."]
        Valid samples.
    total : Float[Array, "... q"]
        Σ z.
    gram : Float[Array, "... q q"]
        Σ z zᵀ.
    lagged : Float[Array, "... q q"]
        ½ Σ (z_t z_(t−1)ᵀ + z_(t−1) z_tᵀ) over neighbouring valid samples.
    batches : Float[Array, "... 3"]
        Per batch length (10 s, 30 s, 60 s): batches with at least half their samples valid.
    batch_total : Float[Array, "... 3 q"]
        Σ of those batches' mean z.
    batch_gram : Float[Array, "... 3 q q"]
        Σ of their mean z's outer products.
    """

    count: Float[Array, "..."]
    total: Float[Array, "... q"]
    gram: Float[Array, "... q q"]
    lagged: Float[Array, "... q q"]
    batches: Float[Array, "... 3"]
    batch_total: Float[Array, "... 3 q"]
    batch_gram: Float[Array, "... 3 q q"]

    @classmethod
    def zeros(cls, q: int, dtype) -> EquationMoments:
        """No samples yet (``q`` regressors)."""

        def z(shape, dtype):
            # NumPy, then one transfer: an eager jnp.zeros is a compiled program of its own.
            return device_array(np.zeros(shape, dtype))

        return cls(
            z((), dtype), z(q, dtype), z((q, q), dtype), z((q, q), dtype),
            z(3, dtype), z((3, q), dtype), z((3, q, q), dtype),
        )  # fmt: skip

    def scaled(self, factor) -> EquationMoments:
        """Every sum times ``factor`` (old data fading)."""
        return jax.tree_util.tree_map(lambda x: factor * x, self)

    def plus(self, other: EquationMoments) -> EquationMoments:
        """These sums and ``other``'s together."""
        return jax.tree_util.tree_map(jnp.add, self, other)

    def block(self, i) -> EquationMoments:
        """Block ``i``'s moments (traceable ``i``) of per-block moments."""
        return jax.tree_util.tree_map(lambda x: x[i], self)


def _batch_level(sums, counts, size):
    """A batch length's count, Σ mean z and Σ mean z mean zᵀ from its batches' sums (last two
    axes: batches, q)."""
    counted = counts >= size / 2
    means = jnp.where(counted[..., None], sums / jnp.maximum(counts, 1.0)[..., None], 0.0)
    return (
        jnp.sum(counted, axis=-1).astype(sums.dtype),
        jnp.sum(means, axis=-2),
        jnp.einsum("...bi,...bj->...ij", means, means),
    )


def equation_moments(
    z: Float[Array, "blocks width q"], mask: Bool[Array, "blocks width"]
) -> EquationMoments:
    """Per-block moments of one equation's regressors ``z`` on ``mask`` (module docstring).

    The 60 s batches pair blocks 0-1, 2-3, …: a pair's moments belong to its second block.

    Examples
    --------
    >>> z = jnp.ones((2, 300, 2)); m = jnp.ones((2, 300), bool)
    >>> mom = equation_moments(z, m)
    >>> [float(x) for x in mom.count], [float(x) for x in mom.batches[1]]
    ([300.0, 300.0], [3.0, 1.0, 1.0])
    """
    dtype = z.dtype
    zm = jnp.where(mask[..., None], z, 0.0)
    both = (mask[:, 1:] & mask[:, :-1])[..., None]
    lag = jnp.einsum("bti,btj->bij", jnp.where(both, zm[:, 1:], 0.0), zm[:, :-1])
    blocks, width, q = z.shape
    n = width - width % CHUNK
    counts = mask.astype(dtype)
    chunk_sum = zm[:, :n].reshape(blocks, -1, CHUNK, q).sum(axis=2)
    chunk_count = counts[:, :n].reshape(blocks, -1, CHUNK).sum(axis=2)
    block_sum, block_count = zm.sum(axis=1), counts.sum(axis=1)
    # The 60 s batch of blocks 2j and 2j + 1, counted at block 2j + 1.
    pair_sum = block_sum + jnp.roll(block_sum, 1, axis=0)
    pair_count = block_count + jnp.roll(block_count, 1, axis=0)
    second = jnp.arange(blocks) % 2 == 1
    levels = [
        _batch_level(chunk_sum, chunk_count, CHUNK),
        _batch_level(block_sum[:, None], block_count[:, None], width),
        _batch_level(
            jnp.where(second[:, None], pair_sum, 0.0)[:, None],
            jnp.where(second, pair_count, 0.0)[:, None],
            2 * width,
        ),
    ]
    batches, batch_total, batch_gram = (jnp.stack(v, axis=1) for v in zip(*levels, strict=True))
    return EquationMoments(
        count=block_count,
        total=block_sum,
        gram=jnp.einsum("bti,btj->bij", zm, zm),
        lagged=0.5 * (lag + jnp.swapaxes(lag, -1, -2)),
        batches=batches,
        batch_total=batch_total,
        batch_gram=batch_gram,
    )


def nominal_axle_forces(
    blocks: LateralBlocks, roll_gain: float
) -> tuple[Float[Array, "blocks width"], Float[Array, "blocks width"]]:
    """ρ̃_f, ρ̃_r: the axle forces over the static loads at the nuisances' medians (no a_y
    offset, the roll gain ``roll_gain``, the vehicle file's J_z), as the batch model's
    :func:`~tyrebayes.inference.lateral.model.axle_state`."""
    lf = blocks.cog_to_front_axle_m
    lr = blocks.wheelbase_m - lf
    a = blocks.ay / (roll_gain * G)
    yaw = blocks.yaw_inertia_kgm2 * blocks.yaw_acceleration / (blocks.mass_kg * G)
    return a + yaw / lr, a - yaw / lf


def steering_regressors(blocks: LateralBlocks, roll_gain: float) -> Float[Array, "blocks width 9"]:
    """z_s = [δ_sw, 1, a_y, ṙ, L r/V_x, ρ̃_f³, ρ̃_r³, ρ̃_f⁵, ρ̃_r⁵] per sample (module
    docstring)."""
    ones = jnp.ones_like(blocks.speed)
    k = blocks.wheelbase_m * blocks.yaw_rate / blocks.speed
    front, rear = nominal_axle_forces(blocks, roll_gain)
    return jnp.stack(
        [
            blocks.steering,
            ones,
            blocks.ay,
            blocks.yaw_acceleration,
            k,
            front**3,
            rear**3,
            front**5,
            rear**5,
        ],  # fmt: skip
        axis=-1,
    )


def kinematic_regressors(blocks: LateralBlocks, roll_gain: float) -> Float[Array, "blocks width 8"]:
    """z_k = [a_y, V_x r + l_r ṙ, 1, d(V_x a_y)/dt, dV_x/dt, d(V_x ṙ)/dt, d(V_x ρ̃_r³)/dt,
    d(V_x ρ̃_r⁵)/dt] per sample, the derivatives by the batch model's five-point stencil within
    each block (module docstring)."""
    v, r, q, a = blocks.speed, blocks.yaw_rate, blocks.yaw_acceleration, blocks.ay
    lr = blocks.wheelbase_m - blocks.cog_to_front_axle_m
    _, rear = nominal_axle_forces(blocks, roll_gain)

    def rows(x):
        return jax.vmap(lambda row: derivative(row, blocks.dt_s))(x)

    return jnp.stack(
        [
            a,
            v * r + lr * q,
            jnp.ones_like(v),
            rows(v * a),
            rows(v),
            rows(v * q),
            rows(v * rear**3),
            rows(v * rear**5),
        ],  # fmt: skip
        axis=-1,
    )


class BlockMoments(eqx.Module):
    """Both equations' per-block moments of a drive (:func:`block_moments`).

    Attributes
    ----------
    steering, kinematic : EquationMoments
        Leading axis: blocks.
    """

    steering: EquationMoments
    kinematic: EquationMoments

    def block(self, i) -> BlockMoments:
        return BlockMoments(self.steering.block(i), self.kinematic.block(i))


def block_moments(blocks: LateralBlocks, roll_gain: float, force_limit: float) -> BlockMoments:
    """The moments of every block of a drive, both equations (vectorised over blocks).

    ``roll_gain`` is the median roll gain the cubic term's axle forces take; samples where an
    axle's force ρ̃ exceeds ``force_limit`` are left out (module docstring).

    Examples
    --------
    >>> from tyrebayes import cornering_observations, lateral_blocks, load_vehicle
    >>> from tyrebayes.simulate.cornering import simulate_cornering
    >>> vehicle = load_vehicle("compact_fwd")
    >>> frame, _ = simulate_cornering(vehicle, duration_s=120.0, seed=3)
    >>> mom = block_moments(lateral_blocks(cornering_observations(frame, vehicle)), 1.06, 0.6)
    >>> mom.steering.gram.shape, mom.kinematic.gram.shape
    ((4, 9, 9), (4, 8, 8))
    """
    front, rear = nominal_axle_forces(blocks, roll_gain)
    linear = jnp.maximum(jnp.abs(front), jnp.abs(rear)) <= force_limit
    return BlockMoments(
        steering=equation_moments(steering_regressors(blocks, roll_gain), blocks.mask & linear),
        kinematic=equation_moments(kinematic_regressors(blocks, roll_gain), blocks.mask_kinematic),
    )


__all__ = [
    "CHUNK",
    "BlockMoments",
    "EquationMoments",
    "block_moments",
    "equation_moments",
    "kinematic_regressors",
    "nominal_axle_forces",
    "steering_regressors",
]

"""Sufficient statistics of the online lateral estimator: each equation's regressors' moments.

Near zero the batch model's tyre curve (the Magic Formula,
:func:`~tyrebayes.physics.magic_formula.magic_formula_inverse_and_slope`) departs from its
tangent by odd powers, α = (ρ/c_y)(1 + λ ρ² + κλ² ρ⁴ + …) with λ = k₃/μ_y² and κ = k₅/k₃²
(:func:`~tyrebayes.physics.magic_formula.magic_formula_inverse_series`; λ_f and λ_r per axle;
κ at the curve priors' medians, where it changes the fifth-order term, itself about 2 % of α at
60 % of the peak, by a fraction of it). To that order both equations of the batch lateral model
(:mod:`tyrebayes.inference.lateral.model`) have residuals that are *linear* in a vector of
coefficients, and the coefficients are functions of the physical parameters. With u = 1/c_f, v =
1/c_r, the roll gain Γ = 1 + g k_φ, the a_y offset b, the steering-wheel offset δ₀, the steering
ratio i_s and the yaw inertia J_z = f·J₀ (P = J₀/(m g)), the steering equation (δ_sw − δ₀)/i_s −
L r/V_x = α_f − α_r reads

    e_s = z_s · c_s,   z_s = [δ_sw, 1, a_y, ṙ, L r/V_x, ρ̃_f³, ρ̃_r³, ρ̃_f⁵, ρ̃_r⁵],
    c_s = [1/i_s, −δ₀/i_s + (u − v) b/(Γ g), −(u − v)/(Γ g), −f P (u/l_r + v/l_f), −1,
           −λ_f u, λ_r v, −κλ_f²u, κλ_r²v],

and the kinematic equation a_y = Γ (V_x r + l_r ṙ − d(V_x α_r)/dt) + b, premultiplied by the
compact derivative's P (D = P⁻¹Q, :func:`~tyrebayes.inference.lateral.sideslip_lag.sideslip_lag`),

    P e_k = z_k · c_k,
    z_k = [P a_y, P(V_x r + l_r ṙ), P 1, Q(V_x a_y), Q V_x, Q(V_x ṙ), Q(V_x ρ̃_r³), Q(V_x ρ̃_r⁵)],
    c_k = [1, −Γ, −b, v/g, −v b/g, −Γ v f P/l_f, Γ v λ_r, Γ v κλ_r²].

The batch model's residual is that error through the rear axle's sideslip lag, Λ(Q + PΛ)⁻¹ P e_k
with Λ = g c_r/V_x in the linear range: it takes out the a_y noise that the slip angle's rate
carries (errors in variables). The lag depends on c_r, so the kinematic moments are taken with
z_k so filtered at each of a few rear stiffnesses (:func:`rear_nodes`) and interpolated in
log c_r between them (:func:`node_weights`).

The curve terms' axle forces ρ̃ are taken at the nuisances' prior medians (no offset, the
median roll gain, the vehicle file's J_z): their error moves terms that are themselves a few
per cent of α by a few per cent of them.

So every sum the estimator needs is a quadratic (or linear) form of the coefficients in
moments of z that do not depend on the parameters (the kinematic ones but for the nodes'
weights): Σe² = cᵀ(Σ z zᵀ)c, the lag-one product Σ e_t e_(t−1) = cᵀ(Σ z_t z_(t−1)ᵀ)c, and
the means of the residuals over the 10 s, 30 s and 60 s batches of the variance inflation
(:mod:`.lateral_vif`) from the batches' mean z. A block's moments are taken once, vectorised
over all blocks (:func:`block_moments`); the estimator then only adds matrices and solves an
eight-parameter problem per block (:mod:`.lateral`).

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
from ..lateral.sideslip_lag import compact_p, compact_q, sideslip_lag, thomas_solve
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
    def zeros(cls, q: int, dtype, lead: tuple[int, ...] = ()) -> EquationMoments:
        """No samples yet (``q`` regressors; ``lead``: leading axes, e.g. the rear nodes')."""

        def z(shape, dtype):
            # NumPy, then one transfer: an eager jnp.zeros is a compiled program of its own.
            return device_array(np.zeros((*lead, *np.atleast_1d(shape).astype(int)), dtype))

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

    def mixed(self, weights: Float[Array, " k"]) -> EquationMoments:
        """Σ_k weights_k × the moments of the k-th entry of the leading axis (the rear nodes')."""
        return jax.tree_util.tree_map(lambda x: jnp.tensordot(weights, x, axes=1), self)


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
    # zm is zero off the mask, so the product of neighbours counts only pairs both valid.
    lag = jnp.einsum("bti,btj->bij", zm[:, 1:], zm[:, :-1])
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
    """z_k = [P a_y, P(V_x r + l_r ṙ), P 1, Q(V_x a_y), Q V_x, Q(V_x ṙ), Q(V_x ρ̃_r³),
    Q(V_x ρ̃_r⁵)] per sample, P and Q the batch model's compact derivative within each block
    (module docstring); before the sideslip lag (:func:`filtered_kinematic_regressors`)."""
    v, r, q, a = blocks.speed, blocks.yaw_rate, blocks.yaw_acceleration, blocks.ay
    lr = blocks.wheelbase_m - blocks.cog_to_front_axle_m
    _, rear = nominal_axle_forces(blocks, roll_gain)
    values = jnp.stack([a, v * r + lr * q, jnp.ones_like(v)], axis=-1)
    rates = jnp.stack([v * a, v, v * q, v * rear**3, v * rear**5], axis=-1)
    return jnp.concatenate(
        [compact_p(values, axis=1), compact_q(rates, blocks.dt_s, axis=1)], axis=-1
    )


def filtered_kinematic_regressors(
    blocks: LateralBlocks, roll_gain: float, c_y_rear: float | Float[Array, ""]
) -> Float[Array, "blocks width 8"]:
    """:func:`kinematic_regressors` through the rear axle's sideslip lag at ``c_y_rear`` (linear
    range, Λ = g c_r/V_x): z_k · c_k is then the batch model's kinematic residual."""
    settling = G * c_y_rear / blocks.speed
    z = kinematic_regressors(blocks, roll_gain)
    return sideslip_lag(z, settling, blocks.mask_kinematic, blocks.dt_s, solve=thomas_solve)


#: Rear stiffnesses at which the kinematic moments are taken, as multiples of the prior median
#: (two-thirds-octave steps, ± 1.4 prior sds: 8.25 to 33 /rad at the default prior, where cars'
#: axles lie): c_r between them is interpolated (:func:`node_weights`), to about 0.2 % of the
#: residual sum of squares (``tests/inference/online/test_lateral_statistics.py``); beyond the
#: ends the end node's moments are used. Each node costs a filter of every block.
NODE_MULTIPLES = tuple(2.0 ** (2 * k / 3 - 1) for k in range(4))


def rear_nodes(c_y_median: float) -> tuple[float, ...]:
    """The rear stiffnesses [1/rad] of the kinematic moments (:data:`NODE_MULTIPLES`).

    Examples
    --------
    >>> [round(c, 1) for c in rear_nodes(16.5)]
    [8.2, 13.1, 20.8, 33.0]
    """
    return tuple(c_y_median * m for m in NODE_MULTIPLES)


def node_weights(log_c_y_rear: Float[Array, ""], nodes: tuple[float, ...]) -> Float[Array, " k"]:
    """Weights of the moments at ``nodes`` that give them at ``log_c_y_rear``: the Catmull-Rom
    cubic in log c_r (continuous slope); beyond the ends, the end node's moments.

    Examples
    --------
    >>> nodes = rear_nodes(16.5)
    >>> [round(float(x), 6) for x in node_weights(jnp.log(nodes[1]), nodes)]
    [0.0, 1.0, 0.0, 0.0]
    >>> w = node_weights(jnp.log(16.5), nodes)
    >>> [round(float(x), 3) for x in w], round(float(w.sum()), 6)
    ([-0.062, 0.562, 0.563, -0.063], 1.0)
    """
    logs = np.log(np.asarray(nodes))
    step = float(logs[1] - logs[0])
    u = jnp.clip((log_c_y_rear - logs[0]) / step, 0.0, len(nodes) - 1.0)
    i = jnp.minimum(jnp.floor(u), len(nodes) - 2.0)
    t = u - i
    t2, t3 = t * t, t * t * t
    cubic = jnp.stack(
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ]
    )
    # Beyond the ends the cubic reads a node extrapolated linearly, M₋₁ = 2M₀ − M₁. Each of the
    # four points adds its weight to the nodes it reads through a one-hot row (no scatter).
    k = len(nodes)
    index = i.astype(jnp.int32) + jnp.arange(-1, 3)
    outside = (index < 0) | (index > k - 1)
    inner = jnp.clip(index, 0, k - 1)
    step_in = jnp.where(index < 0, 1, k - 2)
    columns = jnp.arange(k)[None, :]
    reads = jnp.where(outside[:, None], 2.0, 1.0) * (inner[:, None] == columns) - jnp.where(
        outside[:, None], 1.0, 0.0
    ) * (step_in[:, None] == columns)
    return cubic @ reads


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


def block_moments(
    blocks: LateralBlocks, roll_gain: float, force_limit: float, nodes: tuple[float, ...]
) -> BlockMoments:
    """The moments of every block of a drive, both equations (vectorised over blocks).

    ``roll_gain`` is the median roll gain the cubic term's axle forces take; samples where an
    axle's force ρ̃ exceeds ``force_limit`` are left out (module docstring). The kinematic
    moments have a second axis: one per rear stiffness of ``nodes`` (:func:`rear_nodes`).

    Examples
    --------
    >>> from tyrebayes import cornering_observations, lateral_blocks, load_vehicle
    >>> from tyrebayes.simulate.cornering import simulate_cornering
    >>> vehicle = load_vehicle("compact_fwd")
    >>> frame, _ = simulate_cornering(vehicle, duration_s=120.0, seed=3)
    >>> blocks = lateral_blocks(cornering_observations(frame, vehicle))
    >>> mom = block_moments(blocks, 1.06, 0.6, rear_nodes(16.5))
    >>> mom.steering.gram.shape, mom.kinematic.gram.shape
    ((4, 9, 9), (4, 4, 8, 8))
    """
    front, rear = nominal_axle_forces(blocks, roll_gain)
    linear = jnp.maximum(jnp.abs(front), jnp.abs(rear)) <= force_limit

    def kinematic(c_y_rear):
        z = filtered_kinematic_regressors(blocks, roll_gain, c_y_rear)
        return equation_moments(z, blocks.mask_kinematic)

    per_node = jax.vmap(kinematic)(jnp.asarray(nodes, blocks.speed.dtype))
    return BlockMoments(
        steering=equation_moments(steering_regressors(blocks, roll_gain), blocks.mask & linear),
        kinematic=jax.tree_util.tree_map(lambda x: jnp.moveaxis(x, 0, 1), per_node),
    )


__all__ = [
    "CHUNK",
    "BlockMoments",
    "EquationMoments",
    "block_moments",
    "NODE_MULTIPLES",
    "equation_moments",
    "filtered_kinematic_regressors",
    "kinematic_regressors",
    "node_weights",
    "nominal_axle_forces",
    "rear_nodes",
    "steering_regressors",
]

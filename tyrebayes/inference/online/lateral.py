"""The in-car lateral estimator: c_y front and rear and the understeer gradient, block by block.

The parameters are the batch lateral model's (:mod:`tyrebayes.inference.lateral.model`), on
its unconstrained space (log for the positive sites): log c_y front and rear, log μ_y, the
steering ratio, the steering and a_y offsets, the roll gradient, the yaw inertia's factor, the
curve's shape, and the noise scales of the two equations and of the axle forces. Their
Gaussian starts at the batch model's priors and is updated every :data:`.LATERAL_STEP_S` of
driving by the assumed-density Laplace update of the longitudinal estimator
(:func:`~.laplace_update.laplace_update`: Newton steps to the mode of prior × the block's
likelihood, a Laplace covariance there), where the block's likelihood is the batch model's own
(:func:`~tyrebayes.inference.lateral.model.log_likelihoods` and its peak bound) on the block's
samples, braking samples left out (:mod:`.lateral_blocks`), with its Fisher information as the
curvature (:func:`block_information`).

Correlated residuals: the batch fit weights each equation by 1/VIF of its residuals
(:func:`~tyrebayes.inference.lateral.fit.residual_inflation`). Online, each equation's VIF is
estimated as the residuals at each block's mode arrive, by the batch's rule: the largest of the
AR(1) factor and the batch-means factors at 10, 30 and 60 s (each once :data:`MIN_CHUNKS`
batches are in; batches on the clock, those at least half valid), blended with
:data:`INITIAL_VIF` over the first minute and a half. On real roads the slow batches dominate
(road bank, a curve that misfits over a corner) and need minutes of data to show, so the data's
part of the state is kept as per-equation Gaussian messages, re-weighted by the VIF as it stands
at every step (:class:`LateralState`): the posterior after 10 minutes weights every block by the
VIF of all 10 minutes, as the batch fit does.

A fixed-lag window: the last :data:`WINDOW_BLOCKS` blocks (5 minutes) keep their exact
likelihood, and each step takes Newton steps (from the last mode) to the mode of prior × the
older blocks' messages × the window's likelihood; a block's message is taken only when it leaves
the window, at the mode it helped find. A block linearised where the estimate stood after its
own 30 s (the first minutes, from a wide prior) would fix a wrong linearisation for good: on a
nonlinear front/rear level one early block can pull c_y far off and the narrowed Gaussian never
recovers. The cost is a window's likelihood per step instead of a block's.

Old blocks fade over :data:`MEMORY_S` (slow change of the tyres).

Readiness waits until the VIFs have seen :data:`MIN_CHUNKS` batches of 30 s (4 minutes of
cornering data): before that the intervals leave out slow correlations they have not yet
measured. Then the batch fit's identification rule
(:data:`~tyrebayes.inference.lateral.fit.K_CONTRACTION`) in the Gaussian: the understeer gradient
is reported once its sd is at most half its prior's;
c_y front and rear once, in addition, each axle's log-sd is at most half its prior's: steady
cornering narrows K alone (δ = L/R + K a_y), and only yaw transients tell front from rear.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from ..lateral.data import CorneringObservations
from ..lateral.model import REAL_SITES, LateralPriors, axle_state, residuals, sample_sites
from ..lateral.posterior_checks import K_CONTRACTION
from .laplace_update import laplace_update
from .lateral_blocks import LateralBlocks
from .lateral_summary import LateralTrajectory, OnlineLateral

#: Time constant over which a block's information fades [s]: a tyre's cornering stiffness moves
#: with tread wear, temperature and pressure over hours, not minutes; an hour keeps a 10-minute
#: drive's blocks at 85 % or more of their weight.
MEMORY_S = 3600.0
#: VIF assumed before the residuals say: low-passed at 2 Hz and read at 10 Hz, white noise alone
#: gives an AR(1) factor near 4, and road bank and a curve that misfits over a corner add to it;
#: 10 keeps the first blocks' intervals on the wide side.
INITIAL_VIF = 10.0
#: Weight of :data:`INITIAL_VIF` against the estimate, in 10 s chunks.
VIF_PRIOR_CHUNKS = 8.0
#: Chunk of the batch-means factor [samples] (10 s at 10 Hz), and the batches a length needs to
#: count (the batch fit's ``MIN_BATCHES``).
CHUNK = 100
#: Batch lengths of the batch-means factor [samples]: 10 s, a block (30 s), two blocks (60 s),
#: the batch fit's ``INFLATION_BLOCKS``.
BATCHES = (100, 300, 600)
MIN_CHUNKS = 8
#: Blocks whose likelihood is kept exact and whose messages are taken again at every step
#: (5 minutes): a block's message taken at a mode far from the final one (the first minutes,
#: from a wide prior) would fix a wrong linearisation for good; inside the window it is
#: re-linearised as the estimate settles (a fixed-lag Laplace smoother).
WINDOW_BLOCKS = 10
#: Newton iterations per block at most, and the step (in posterior sds) that ends them.
NEWTON_STEPS = 12
NEWTON_TOLERANCE = 0.05


def site_names(priors: LateralPriors, road_wheel: bool = False) -> tuple[str, ...]:
    """The state's coordinates: the batch model's sites for ``priors``' effects.

    The steering ratio is kept where the log gives a road-wheel angle: the likelihood does not
    read it then, and it stays at its prior.

    Examples
    --------
    >>> site_names(LateralPriors())[:3]
    ('c_y_front', 'c_y_rear', 'mu_y')
    """
    del road_wheel
    return sample_sites(priors)


class LateralPrior(eqx.Module):
    """The Gaussian over the unconstrained coordinates the estimator starts from.

    Attributes
    ----------
    mean : Float[Array, "p"]
    cov : Float[Array, "p p"]
    names : tuple of str
        The coordinates (:func:`site_names`).
    """

    mean: Float[Array, " p"]
    cov: Float[Array, "p p"]
    names: tuple[str, ...] = eqx.field(static=True)

    def __check_init__(self):
        p = len(self.names)
        if self.mean.shape != (p,) or self.cov.shape != (p, p):
            raise ValueError(
                f"LateralPrior: expected mean ({p},) and cov ({p}, {p}), "
                f"got {self.mean.shape} and {self.cov.shape}"
            )


def lateral_prior(
    priors: LateralPriors | None = None, *, surface: str = "dry", steering_ratio: float = 15.0
) -> LateralPrior:
    """The batch model's priors as a Gaussian on its unconstrained space (independent sites).

    Examples
    --------
    >>> prior = lateral_prior()
    >>> round(float(jnp.exp(prior.mean[0])), 2), round(float(jnp.sqrt(prior.cov[0, 0])), 2)
    (16.5, 0.5)
    """
    priors = LateralPriors() if priors is None else priors
    mu, mu_log_sd = priors.mu_y_prior(surface)
    centre_sd = {
        "c_y_front": (math.log(priors.c_y_median), priors.c_y_log_sd),
        "c_y_rear": (math.log(priors.c_y_median), priors.c_y_log_sd),
        "mu_y": (math.log(mu), mu_log_sd),
        "steering_ratio": (math.log(steering_ratio), priors.steering_ratio_log_sd),
        "steering_offset": (0.0, priors.steering_offset_sd_rad),
        "ay_offset": (0.0, priors.ay_offset_sd),
        "roll_gradient": (math.log(priors.roll_gradient_median), priors.roll_gradient_log_sd),
        "yaw_inertia_factor": (0.0, priors.yaw_inertia_log_sd),
        "relaxation_length": (
            math.log(priors.relaxation_length_median_m),
            priors.relaxation_length_log_sd,
        ),
        "curve_shape_excess": (
            priors.curve_shape_excess_log_mean,
            priors.curve_shape_excess_log_sd,
        ),
        "curve_curvature_gap": (
            priors.curve_curvature_gap_log_mean,
            priors.curve_curvature_gap_log_sd,
        ),
        "steer_noise": (math.log(priors.steer_noise_median), 1.0),
        "kinematic_noise": (math.log(priors.kinematic_noise_median), 1.0),
        "force_noise": (math.log(priors.force_noise_median), 1.0),
    }
    names = site_names(priors)
    mean = jnp.asarray([centre_sd[n][0] for n in names])
    sd = jnp.asarray([centre_sd[n][1] for n in names])
    return LateralPrior(mean=mean, cov=jnp.diag(sd**2), names=names)


def constrained(theta: Float[Array, " p"], names: tuple[str, ...]) -> dict:
    """The model's parameters at the unconstrained point ``theta``."""
    return {n: theta[i] if n in REAL_SITES else jnp.exp(theta[i]) for i, n in enumerate(names)}


def _terms(theta, obs: CorneringObservations, names: tuple[str, ...], priors: LateralPriors):
    """Per sample: the steering residual and the log of its sd, the kinematic residual and the
    log of its sd, and the excess of an axle's force over μ_y in units of the peak margin."""
    p = constrained(theta, names)
    state = axle_state(obs, p)
    steer, kinematic = residuals(obs, p)
    log_steer_sd = 0.5 * jnp.log(
        p["steer_noise"] ** 2 + p["force_noise"] ** 2 * (state.slope_front**2 + state.slope_rear**2)
    )
    log_kin_sd = jnp.broadcast_to(jnp.log(p["kinematic_noise"]), kinematic.shape)
    peak = jnp.maximum(jnp.abs(state.rho_front), jnp.abs(state.rho_rear))
    beyond = jnp.maximum(peak - p["mu_y"], 0.0) / priors.peak_margin
    return steer, log_steer_sd, kinematic, log_kin_sd, beyond


def block_parts(
    theta: Float[Array, " p"],
    obs: CorneringObservations,
    names: tuple[str, ...],
    priors: LateralPriors,
) -> tuple[Float[Array, "3"], Float[Array, "3 p"], Float[Array, "3 p p"]]:
    """The block's log-likelihood at ``theta`` in three parts (steering equation, kinematic
    equation, peak bound; unweighted): each part's value, gradient and Fisher information.

    The likelihood is the batch model's (:func:`~tyrebayes.inference.lateral.model.lateral_model`):
    each equation's Normal terms on its mask and the peak bound (an axle cannot give more than
    μ_y); the priors are the filter's Gaussian, not here. For a Normal term with residual e and
    sd σ the Fisher information is ∇e∇eᵀ/σ² + 2∇log σ∇log σᵀ, for the peak bound its
    Gauss-Newton matrix: all from one forward-mode Jacobian of the per-sample terms, about a
    third of the exact Hessian's cost (which also bends the wrong way far from the mode), and
    gradient and value from the same pass.
    """

    def terms(t):
        return _terms(t, obs, names, priors)

    values, jacobians = jax.vmap(lambda e: jax.jvp(terms, (theta,), (e,)), out_axes=(None, 1))(
        jnp.eye(theta.shape[0], dtype=theta.dtype)
    )
    steer, log_steer_sd, kin, log_kin_sd, beyond = values
    j_steer, j_steer_sd, j_kin, j_kin_sd, j_beyond = jacobians
    ms = obs.mask.astype(theta.dtype)
    mk = obs.mask_kinematic.astype(theta.dtype)
    zs = jnp.where(obs.mask, steer * jnp.exp(-log_steer_sd), 0.0)
    zk = jnp.where(obs.mask_kinematic, kin * jnp.exp(-log_kin_sd), 0.0)
    bb = jnp.where(obs.mask, beyond, 0.0)
    inv_s = jnp.where(obs.mask, jnp.exp(-log_steer_sd), 0.0)
    inv_k = jnp.where(obs.mask_kinematic, jnp.exp(-log_kin_sd), 0.0)
    value = jnp.stack(
        [
            jnp.sum(ms * (-0.5 * zs**2 - log_steer_sd)),
            jnp.sum(mk * (-0.5 * zk**2 - log_kin_sd)),
            -0.5 * jnp.sum(bb**2),
        ]
    )
    # ∂/∂θ of −½ z² − log σ with z = e/σ: −z/σ ∇e + (z² − 1) ∇log σ.
    gradient = jnp.stack(
        [
            (-zs * inv_s) @ j_steer + (ms * (zs**2 - 1.0)) @ j_steer_sd,
            (-zk * inv_k) @ j_kin + (mk * (zk**2 - 1.0)) @ j_kin_sd,
            -bb @ j_beyond,
        ]
    )
    scaled_s = j_steer * inv_s[:, None]
    scaled_k = j_kin * inv_k[:, None]
    sd_s = j_steer_sd * jnp.sqrt(2.0 * ms)[:, None]
    sd_k = j_kin_sd * jnp.sqrt(2.0 * mk)[:, None]
    peak = jnp.where(obs.mask[:, None], j_beyond, 0.0)
    information = jnp.stack(
        [
            scaled_s.T @ scaled_s + sd_s.T @ sd_s,
            scaled_k.T @ scaled_k + sd_k.T @ sd_k,
            peak.T @ peak,
        ]
    )
    return value, gradient, information


def block_information(
    theta: Float[Array, " p"],
    obs: CorneringObservations,
    weights: Float[Array, "2"],
    names: tuple[str, ...],
    priors: LateralPriors,
) -> tuple[Float[Array, ""], Float[Array, " p"], Float[Array, "p p"]]:
    """The block's log-likelihood at ``theta`` with the equations weighted 1/VIF, its gradient
    and its Fisher information (:func:`block_parts`, the peak bound unweighted)."""
    value, gradient, information = block_parts(theta, obs, names, priors)
    w = jnp.concatenate([weights, jnp.ones(1, weights.dtype)])
    return w @ value, w @ gradient, jnp.einsum("k,kij->ij", w, information)


def block_log_likelihood(
    theta: Float[Array, " p"],
    obs: CorneringObservations,
    weights: Float[Array, "2"],
    names: tuple[str, ...],
    priors: LateralPriors,
) -> Float[Array, ""]:
    """The block's log-likelihood at ``theta`` alone (:func:`block_information`'s value)."""
    steer, log_steer_sd, kin, log_kin_sd, beyond = _terms(theta, obs, names, priors)
    zs = steer * jnp.exp(-log_steer_sd)
    zk = kin * jnp.exp(-log_kin_sd)
    return (
        weights[0] * jnp.sum(jnp.where(obs.mask, -0.5 * zs**2 - log_steer_sd, 0.0))
        + weights[1] * jnp.sum(jnp.where(obs.mask_kinematic, -0.5 * zk**2 - log_kin_sd, 0.0))
        - 0.5 * jnp.sum(jnp.where(obs.mask, beyond**2, 0.0))
    )


class ResidualMoments(eqx.Module):
    """Running sums of one equation's residuals for its VIF (module docstring).

    Attributes
    ----------
    count, total, squares, lagged : Float[Array, ""]
        Samples, Σr, Σr², Σ r_t r_(t−1) over neighbouring valid samples.
    batches, batch_total, batch_squares : Float[Array, " levels"]
        Per batch length of :data:`BATCHES` (10, 30, 60 s): batches with at least half their
        samples valid, Σ of their means, Σ of their squares.
    pending_sum, pending_count : Float[Array, ""]
        Σr and samples of the block before, while a 60 s batch is half full.
    pending : Bool[Array, ""]
        Whether a 60 s batch is half full.
    sizes : Float[Array, " levels"]
        The batch lengths [samples]: 10 s, a block, two blocks.
    """

    count: Float[Array, ""]
    total: Float[Array, ""]
    squares: Float[Array, ""]
    lagged: Float[Array, ""]
    batches: Float[Array, " levels"]
    batch_total: Float[Array, " levels"]
    batch_squares: Float[Array, " levels"]
    pending_sum: Float[Array, ""]
    pending_count: Float[Array, ""]
    pending: Bool[Array, ""]
    sizes: Float[Array, " levels"]

    @classmethod
    def empty(cls, dtype) -> ResidualMoments:
        zero = jnp.zeros((), dtype)
        levels = jnp.zeros(len(BATCHES), dtype)
        sizes = jnp.asarray(BATCHES, dtype)
        return cls(
            zero, zero, zero, zero, levels, levels, levels, zero, zero, jnp.array(False), sizes
        )

    def add(self, r: Float[Array, " n"], mask: Bool[Array, " n"]) -> ResidualMoments:
        """These sums with a block's residuals ``r`` on ``mask`` added (a block is 30 s: three
        10 s batches, one 30 s batch, half of a 60 s batch)."""
        x = jnp.where(mask, r, 0.0)
        both = mask[1:] & mask[:-1]
        dtype = x.dtype
        n = x.shape[0] - x.shape[0] % CHUNK
        chunk_sum = jnp.sum(x[:n].reshape(-1, CHUNK), axis=1)
        chunk_count = jnp.sum(mask[:n].reshape(-1, CHUNK), axis=1).astype(dtype)
        block_sum, block_count = jnp.sum(x), jnp.sum(mask).astype(dtype)
        pair_sum, pair_count = self.pending_sum + block_sum, self.pending_count + block_count

        def level(sums, counts, size, when=True):
            counted = when & (counts >= size // 2)
            means = jnp.where(counted, sums / jnp.maximum(counts, 1.0), 0.0)
            return jnp.sum(counted).astype(dtype), jnp.sum(means), jnp.sum(means**2)

        width = x.shape[0]
        levels = [
            level(chunk_sum, chunk_count, CHUNK),
            level(block_sum, block_count, width),
            level(pair_sum, pair_count, 2 * width, when=self.pending),
        ]
        added = [jnp.stack(v) for v in zip(*levels, strict=True)]
        return ResidualMoments(
            count=self.count + block_count,
            total=self.total + block_sum,
            squares=self.squares + jnp.sum(x**2),
            lagged=self.lagged + jnp.sum(jnp.where(both, x[1:] * x[:-1], 0.0)),
            batches=self.batches + added[0],
            batch_total=self.batch_total + added[1],
            batch_squares=self.batch_squares + added[2],
            pending_sum=jnp.where(self.pending, 0.0, block_sum),
            pending_count=jnp.where(self.pending, 0.0, block_count),
            pending=~self.pending,
            sizes=jnp.asarray([CHUNK, width, 2 * width], dtype),
        )

    def inflation(self) -> Float[Array, ""]:
        """The VIF in use: the estimate (AR(1) and batch means, the batch fit's rule), blended
        with :data:`INITIAL_VIF` over the first :data:`VIF_PRIOR_CHUNKS` 10 s of data."""
        n = jnp.maximum(self.count, 1.0)
        centre = self.total / n
        var = jnp.maximum(self.squares / n - centre**2, 1e-30)
        phi = jnp.clip((self.lagged / n - centre**2) / var, 0.0, 0.995)
        ar1 = (1.0 + phi) / (1.0 - phi)
        batches = jnp.maximum(self.batches, 1.0)
        batch_var = self.batch_squares / batches - (self.batch_total / batches) ** 2
        factors = jnp.where(self.batches >= MIN_CHUNKS, self.sizes * batch_var / var, 1.0)
        estimate = jnp.where(
            self.count >= 20, jnp.maximum(jnp.maximum(ar1, jnp.max(factors)), 1.0), 1.0
        )
        seen = self.count / CHUNK
        return (VIF_PRIOR_CHUNKS * INITIAL_VIF + seen * estimate) / (VIF_PRIOR_CHUNKS + seen)


class Window(eqx.Module):
    """The samples of the last blocks (oldest first); empty rows fully masked.

    Attributes
    ----------
    speed, yaw_rate, yaw_acceleration, ay, steering : Float[Array, "w width"]
    mask, mask_kinematic : Bool[Array, "w width"]
    """

    speed: Float[Array, "w width"]
    yaw_rate: Float[Array, "w width"]
    yaw_acceleration: Float[Array, "w width"]
    ay: Float[Array, "w width"]
    steering: Float[Array, "w width"]
    mask: Bool[Array, "w width"]
    mask_kinematic: Bool[Array, "w width"]

    @classmethod
    def empty(cls, blocks: int, width: int, dtype) -> Window:
        zeros = jnp.zeros((blocks, width), dtype)
        false = jnp.zeros((blocks, width), bool)
        return cls(zeros + 10.0, zeros, zeros, zeros, zeros, false, false)

    def pushed(self, obs: CorneringObservations) -> Window:
        """The window with ``obs`` appended and the oldest block dropped."""

        def push(rows, new):
            return jnp.concatenate([rows[1:], new[None]], axis=0)

        return Window(
            *(
                push(getattr(self, f), getattr(obs, f))
                for f in (
                    "speed",
                    "yaw_rate",
                    "yaw_acceleration",
                    "ay",
                    "steering",
                    "mask",
                    "mask_kinematic",
                )
            )
        )

    def block(self, i, like: CorneringObservations) -> CorneringObservations:
        """Row ``i`` as observations, with ``like``'s constants."""
        return eqx.tree_at(
            lambda o: (
                o.speed,
                o.yaw_rate,
                o.yaw_acceleration,
                o.ay,
                o.steering,
                o.mask,
                o.mask_kinematic,
            ),
            like,
            (
                self.speed[i],
                self.yaw_rate[i],
                self.yaw_acceleration[i],
                self.ay[i],
                self.steering[i],
                self.mask[i],
                self.mask_kinematic[i],
            ),
        )


class LateralState(eqx.Module):
    """The estimator's state after a block.

    The data's part is kept as Gaussian messages per likelihood part (steering equation,
    kinematic equation, peak bound), unweighted: each block adds its Fisher information J at
    its mode θ* and J θ* + ∇ℓ(θ*). The posterior is the prior times the messages, the
    equations' weighted by 1/VIF as estimated *now*: a VIF that grows as slower correlations
    show (30 s and 60 s batches need minutes of data) re-weights every earlier block, as the
    batch fit's one VIF weights all of its samples.

    Attributes
    ----------
    mean, cov : Array
        The posterior Gaussian over the unconstrained coordinates.
    information : Float[Array, "3 p p"]
        Σ of the blocks' J, per part.
    shift : Float[Array, "3 p"]
        Σ of the blocks' J θ* + ∇ℓ(θ*), per part.
    time_s : Float[Array, ""]
        Time of the last block's end [s].
    steering, kinematic : ResidualMoments
        The two equations' residual sums (their VIFs).
    n_samples, n_skipped : Float[Array, ""]
        Samples that entered the steering equation; samples left out for |a_x|.
    window : Window
        The last :data:`WINDOW_BLOCKS` blocks' samples, whose likelihood is kept exact (their
        messages are not in ``information``/``shift``).
    """

    mean: Float[Array, " p"]
    cov: Float[Array, "p p"]
    information: Float[Array, "3 p p"]
    shift: Float[Array, "3 p"]
    window: Window
    time_s: Float[Array, ""]
    steering: ResidualMoments
    kinematic: ResidualMoments
    n_samples: Float[Array, ""]
    n_skipped: Float[Array, ""]


def _symmetric_inverse(matrix: Float[Array, "p p"]) -> Float[Array, "p p"]:
    """Inverse of a precision (positive definite by construction: a prior's plus Fisher
    informations), by Cholesky."""
    factor = jnp.linalg.cholesky(0.5 * (matrix + matrix.T))
    return jax.scipy.linalg.cho_solve((factor, True), jnp.eye(matrix.shape[0], dtype=matrix.dtype))


def _settled(state: LateralState) -> Bool[Array, ""]:
    """Whether both equations' VIFs have seen :data:`MIN_CHUNKS` batches of a block's length
    (30 s): before that the slow correlations that dominate on real roads are not measured,
    and the intervals, however narrow, are not yet trusted (readiness waits for it)."""
    return (state.steering.batches[1] >= MIN_CHUNKS) & (state.kinematic.batches[1] >= MIN_CHUNKS)


class OnlineLateralEstimator(eqx.Module):
    """Recursive estimator of a car's lateral tyre parameters (module docstring).

    Attributes
    ----------
    prior : LateralPrior
    priors : LateralPriors
        The batch model's prior scales (its peak margin, its effects).
    memory_s : float
        Time constant over which old blocks' messages fade [s] (:data:`MEMORY_S`).
    newton_steps : int
    newton_tolerance : float
    """

    prior: LateralPrior
    priors: LateralPriors = eqx.field(static=True)
    memory_s: float = eqx.field(static=True, default=None)
    newton_steps: int = eqx.field(static=True, default=NEWTON_STEPS)
    newton_tolerance: float = eqx.field(static=True, default=NEWTON_TOLERANCE)

    @classmethod
    def create(
        cls,
        *,
        priors: LateralPriors | None = None,
        surface: str = "dry",
        steering_ratio: float = 15.0,
    ) -> OnlineLateralEstimator:
        """An estimator from the batch model's priors (``steering_ratio``: the vehicle file's).

        Examples
        --------
        >>> OnlineLateralEstimator.create().prior.names[-1]
        'force_noise'
        """
        priors = LateralPriors() if priors is None else priors
        prior = lateral_prior(priors, surface=surface, steering_ratio=steering_ratio)
        return cls(prior=prior, priors=priors, memory_s=MEMORY_S)

    def init(self, width: int = 300) -> LateralState:
        """The state before any block of ``width`` samples: the prior."""
        dtype = self.prior.mean.dtype
        zero = jnp.zeros((), dtype)
        p = self.prior.mean.shape[0]
        return LateralState(
            mean=self.prior.mean,
            cov=self.prior.cov,
            information=jnp.zeros((3, p, p), dtype),
            shift=jnp.zeros((3, p), dtype),
            time_s=zero,
            steering=ResidualMoments.empty(dtype),
            kinematic=ResidualMoments.empty(dtype),
            n_samples=zero,
            n_skipped=zero,
            window=Window.empty(WINDOW_BLOCKS, width, dtype),
        )

    def _posterior(self, information, shift, steering, kinematic):
        """The prior times the messages, the equations weighted 1/VIF: mean and covariance."""
        w = jnp.stack(
            [1.0 / steering.inflation(), 1.0 / kinematic.inflation(), jnp.ones(())]
        ).astype(shift.dtype)
        prior_precision = _symmetric_inverse(self.prior.cov)
        precision = prior_precision + jnp.einsum("k,kij->ij", w, information)
        cov = _symmetric_inverse(precision)
        mean = cov @ (prior_precision @ self.prior.mean + w @ shift)
        return mean, cov, w[:2]

    def update(
        self, state: LateralState, obs: CorneringObservations, time_s, skipped
    ) -> LateralState:
        """One block: the oldest window block's message frozen, the new block in, the mode of
        prior × frozen messages × the window's exact likelihood, the residuals' sums."""
        names = self.prior.names
        elapsed = jnp.maximum(time_s - state.time_s, 0.0)
        fade = jnp.exp(-elapsed / self.memory_s)
        # The block leaving the window: its message at the latest mode, which it helped find.
        _, gradient, leaving = block_parts(
            state.mean, state.window.block(0, obs), names, self.priors
        )
        information = fade * (state.information + leaving)
        shift = fade * (state.shift + jnp.einsum("kij,j->ki", leaving, state.mean) + gradient)
        window = state.window.pushed(obs)
        mean, cov, weights = self._posterior(information, shift, state.steering, state.kinematic)
        precision = _symmetric_inverse(cov)
        start = state.mean
        rows = jnp.arange(WINDOW_BLOCKS)

        def window_parts(theta):
            return jax.vmap(
                lambda i: block_information(
                    theta, window.block(i, obs), weights, names, self.priors
                )
            )(rows)

        # Newton from the latest mode, not the frozen messages' mean: the objective
        # ½(θ − m)ᵀP⁻¹(θ − m) − ℓ(θ) written about ``start`` (laplace_update's mean) by moving
        # the difference of the two quadratics into the likelihood.
        def moved(theta):
            d, e = theta - mean, theta - start
            return -0.5 * d @ precision @ d + 0.5 * e @ precision @ e

        def log_likelihood(theta):
            value = jax.vmap(
                lambda i: block_log_likelihood(
                    theta, window.block(i, obs), weights, names, self.priors
                )
            )(rows)
            return jnp.sum(value) + moved(theta)

        def curvature(theta):
            value, gradient, info = window_parts(theta)
            return (
                jnp.sum(value) + moved(theta),
                jnp.sum(gradient, axis=0) + precision @ (mean - start),
                jnp.sum(info, axis=0),
            )

        mode = laplace_update(
            log_likelihood,
            start,
            cov,
            self.newton_steps,
            self.newton_tolerance,
            curvature=curvature,
        ).mean
        steer, kinematic = residuals(obs, constrained(mode, names))
        steering = state.steering.add(steer, obs.mask)
        kinematic = state.kinematic.add(kinematic, obs.mask_kinematic)
        _, gradient, block = jax.vmap(
            lambda i: block_parts(mode, window.block(i, obs), names, self.priors)
        )(rows)
        window_information = jnp.sum(block, axis=0)
        window_shift = jnp.einsum("kij,j->ki", window_information, mode) + jnp.sum(gradient, 0)
        mean, cov, _ = self._posterior(
            information + window_information, shift + window_shift, steering, kinematic
        )
        return LateralState(
            mean=mean,
            cov=cov,
            information=information,
            shift=shift,
            window=window,
            time_s=jnp.maximum(time_s, state.time_s),
            steering=steering,
            kinematic=kinematic,
            n_samples=state.n_samples + jnp.sum(obs.mask),
            n_skipped=state.n_skipped + skipped,
        )

    def run(
        self, state: LateralState, blocks: LateralBlocks
    ) -> tuple[LateralState, LateralTrajectory]:
        """Scan :meth:`update` over the blocks; the last state and each block's moments."""
        index = {n: i for i, n in enumerate(self.prior.names)}
        rows = jnp.asarray([index["c_y_front"], index["c_y_rear"]])

        def step(carry, i):
            new = self.update(carry, blocks.block(i), blocks.time_s[i], blocks.n_skipped[i])
            moments = (new.time_s, new.mean[rows], new.cov[rows[:, None], rows[None, :]])
            return new, (*moments, _settled(new))

        last, (time_s, mean, cov, settled) = jax.lax.scan(step, state, jnp.arange(blocks.n_blocks))
        return last, LateralTrajectory(
            time_s=time_s, log_c_y_mean=mean, log_c_y_cov=cov, vif_settled=settled
        )

    def result(self, state: LateralState) -> OnlineLateral:
        """The estimate of a state (readiness included, module docstring)."""
        index = {n: i for i, n in enumerate(self.prior.names)}
        rows = [index["c_y_front"], index["c_y_rear"]]
        return OnlineLateral(
            mean=state.mean,
            cov=state.cov,
            names=self.prior.names,
            time_s=state.time_s,
            prior_log_c_y_mean=self.prior.mean[rows[0]],
            prior_log_c_y_sd=jnp.sqrt(self.prior.cov[rows[0], rows[0]]),
            contraction=K_CONTRACTION,
            n_samples=state.n_samples,
            n_skipped_longitudinal=state.n_skipped,
            steering_vif=state.steering.inflation(),
            kinematic_vif=state.kinematic.inflation(),
            vif_settled=_settled(state),
        )


@eqx.filter_jit
def run_online_lateral(
    estimator: OnlineLateralEstimator, state: LateralState, blocks: LateralBlocks
) -> tuple[LateralState, LateralTrajectory]:
    """:meth:`OnlineLateralEstimator.run`, compiled (once per block shape and settings)."""
    return estimator.run(state, blocks)


def online_lateral(
    blocks: LateralBlocks,
    *,
    priors: LateralPriors | None = None,
    surface: str = "dry",
) -> tuple[OnlineLateral, LateralTrajectory]:
    """Run the lateral estimator from the batch priors over a drive's blocks (the command's path).

    Parameters
    ----------
    blocks : LateralBlocks
        From :func:`~.lateral_blocks.lateral_blocks`.
    priors : LateralPriors, optional
    surface : str
        Road surface: the centre of μ_y's prior.

    Returns
    -------
    OnlineLateral, LateralTrajectory
        The estimate after the last block, and each block's c_y moments.

    Examples
    --------
    >>> result, trajectory = online_lateral(lateral_blocks(obs))  # doctest: +SKIP
    >>> result.to_dict()["understeer_gradient"]  # doctest: +SKIP
    """
    estimator = OnlineLateralEstimator.create(
        priors=priors, surface=surface, steering_ratio=float(blocks.steering_ratio)
    )
    last, trajectory = run_online_lateral(estimator, estimator.init(blocks.speed.shape[1]), blocks)
    return estimator.result(last), trajectory


__all__ = [
    "MEMORY_S",
    "block_parts",
    "LateralPrior",
    "LateralState",
    "OnlineLateralEstimator",
    "ResidualMoments",
    "block_information",
    "block_log_likelihood",
    "lateral_prior",
    "online_lateral",
    "run_online_lateral",
    "site_names",
]

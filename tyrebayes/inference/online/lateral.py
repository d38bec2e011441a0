"""The in-car lateral estimator: c_y front and rear and the understeer gradient, block by block.

The model is the batch lateral model's (:mod:`tyrebayes.inference.lateral.model`) with each
axle's tyre curve to fifth order, α = (ρ/c_y)(1 + λρ² + κλ²ρ⁴), λ per axle as the batch
model's curve shape is: there both of its equations have residuals
linear in a vector of coefficients that are functions of the physical parameters, so a drive's
data enter only through the moments of the equations' regressors (:mod:`.lateral_statistics`),
taken once per block, vectorised; the kinematic equation's at a few rear stiffnesses, between
which they are interpolated (its residual passes through the rear axle's sideslip lag, which
depends on c_r). The parameters are seven of the batch model's, on its
unconstrained space: log c_y front and rear, the steering ratio, the steering and a_y offsets,
the roll gradient and the yaw inertia's factor, and log λ of each axle (:func:`linear_sites`).
Their Gaussian prior is the batch model's; each λ's is what the batch model's priors of the
curve's shape and of μ_y imply (:func:`~.lateral_curve.cubic_prior`), independently per axle
(μ_y is shared in the batch model, so the two λ are correlated there through it; the
estimator does not carry μ_y).

Every :data:`~.lateral_blocks.LATERAL_STEP_S` of driving the block's moments are added to the
faded sums and the posterior's mode is found again by Gauss-Newton steps (each equation's Jᵀ(Σ z
zᵀ)J, J = ∂c/∂θ) from the last one, on the exact log-posterior of all data so far: each
equation's noise variance integrated out under a weak inverse-gamma prior (one pseudo-sample at
the batch model's median noise), so an equation with n samples and residual sum of squares
RSS(θ) adds

    −½ (ν₀ + n/VIF) log(ν₀ σ₀² + RSS(θ)/VIF),

where VIF is the equation's variance inflation at the last mode, by the batch fit's rule
(:mod:`.lateral_vif`). The covariance is the inverse of the exact Hessian at the mode
(Laplace), or of the Fisher information where that is not positive definite. Because the sums
hold every sample, a block never fixes an early, wrong linearisation: the posterior after 10
minutes is that of the fifth-order model on all 10 minutes, whatever the order of the data.

Near the curve's peak the series reads c_y low; the steering equation leaves those samples out
(:data:`~.lateral_curve.PEAK_SHARE`), and the benchmark compares against the batch fit's full
Magic Formula (``benchmarks/online_lateral.py``).

Old blocks fade over :data:`MEMORY_S` (slow change of the tyres).

Readiness waits until the VIFs have seen :data:`~.lateral_vif.MIN_CHUNKS` batches of 30 s
(4 minutes of data): before that the intervals leave out slow correlations they have not yet
measured. Then the batch fit's identification rule
(:data:`~tyrebayes.inference.lateral.posterior_checks.K_CONTRACTION`) in the Gaussian: the
understeer gradient is reported once its sd is at most half its prior's; c_y front and rear
once, in addition, each axle's log-sd is at most half its prior's: steady cornering narrows K
alone (δ = L/R + K a_y), and only yaw transients tell front from rear.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float
from scipy.linalg import block_diag

from ...internal.device_arrays import device_array
from ...internal.stored_program import stored_program
from ...physics.magic_formula import magic_formula_inverse_series
from ..lateral.data import G
from ..lateral.model import NULL_VALUES, LateralPriors
from ..lateral.posterior_checks import K_CONTRACTION
from .lateral_blocks import LateralBlocks
from .lateral_curve import PEAK_SHARE, cubic_prior, curve_medians
from .lateral_prior import LateralPrior, lateral_prior
from .lateral_run import LateralRun
from .lateral_sites import CUBIC_SITES, LINEAR_SITES, linear_sites
from .lateral_state import LateralState
from .lateral_statistics import (
    CHUNK,
    BlockMoments,
    EquationMoments,
    block_moments,
    node_weights,
    rear_nodes,
)
from .lateral_summary import LateralTrajectory, OnlineLateral
from .lateral_vif import inflation

#: Time constant over which a block's information fades [s]: a tyre's cornering stiffness moves
#: with tread wear, temperature and pressure over hours, not minutes; an hour keeps a 10-minute
#: drive's blocks at 85 % or more of their weight.
MEMORY_S = 3600.0
#: Gauss-Newton iterations per block at most, and the step (in posterior sds) that ends them:
#: each starts from the last block's mode, which one block of 30 s moves little.
NEWTON_STEPS = 10
NEWTON_TOLERANCE = 0.01
#: Blocks per compiled call of :func:`online_lateral` (8 minutes): a drive of any length runs
#: as calls on this many blocks, so that one program serves every drive (a fleet worker traces
#: it once).
RUN_BLOCKS = 16
#: Pseudo-samples of each equation's noise-variance prior (inverse-gamma): enough to keep a
#: block without cornering from claiming a zero residual, too few to matter once a corner is in.
NOISE_PSEUDO_SAMPLES = 1.0
#: Steps tried along each Gauss-Newton direction (the best is kept, the current point included).
_STEP_SCALES = (1.0, 0.5, 0.25, 0.0625, 0.0)


class OnlineLateralEstimator(eqx.Module):
    """Recursive estimator of a car's lateral tyre parameters (module docstring).

    Attributes
    ----------
    prior : LateralPrior
        The Gaussian over :func:`linear_sites`.
    noise_scales : tuple of float
        The noise-variance priors' scales σ₀ of the steering [rad] and kinematic [m/s²]
        equations: the batch model's medians.
    roll_gain : float
        The roll gain at its prior median, where the curve terms' axle forces are taken.
    force_limit : float
        The steering equation reads samples whose axle forces stay below it
        (:data:`~.lateral_curve.PEAK_SHARE` of μ_y's prior median).
    quintic_ratio : float
        κ = k₅/k₃² of the curve at its priors' medians (:mod:`.lateral_statistics`).
    rear_nodes : tuple of float
        Rear stiffnesses [1/rad] at which the kinematic moments are taken and between which
        they are interpolated (:func:`~.lateral_statistics.rear_nodes`).
    memory_s : float
        Time constant over which old blocks' moments fade [s] (:data:`MEMORY_S`).
    newton_steps : int
    """

    prior: LateralPrior
    noise_scales: tuple[float, float] = eqx.field(static=True)
    roll_gain: float = eqx.field(static=True)
    force_limit: float = eqx.field(static=True)
    quintic_ratio: float = eqx.field(static=True)
    rear_nodes: tuple[float, ...] = eqx.field(static=True)
    memory_s: float = eqx.field(static=True, default=MEMORY_S)
    newton_steps: int = eqx.field(static=True, default=NEWTON_STEPS)

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
        >>> OnlineLateralEstimator.create().prior.names[-2:]
        ('curve_cubic_front', 'curve_cubic_rear')
        """
        priors = LateralPriors() if priors is None else priors
        full = lateral_prior(priors, surface=surface, steering_ratio=steering_ratio)
        names = linear_sites(priors)
        cubic = sum(n in CUBIC_SITES for n in names)
        rows = [full.names.index(n) for n in names[:-cubic]]
        cubic_mean, cubic_sd = cubic_prior(priors, surface)
        # In NumPy: each eager JAX operation would be a compiled program of its own, compiled
        # again by a fleet worker after it drops its programs.
        mean, cov = np.asarray(full.mean), np.asarray(full.cov)
        prior = LateralPrior(
            mean=device_array(np.append(mean[rows], np.full(cubic, cubic_mean))),
            cov=device_array(block_diag(cov[np.ix_(rows, rows)], cubic_sd**2 * np.eye(cubic))),
            names=names,
        )
        # The steering equation's noise: the sensor's and the axle forces' through the slope
        # dα/dρ = 1/c_y of each axle (the batch model's errors in variables, linear range).
        steer = math.hypot(
            priors.steer_noise_median,
            math.sqrt(2.0) * priors.force_noise_median / priors.c_y_median,
        )
        roll = priors.roll_gradient_median if "roll" in priors.effects else 0.0
        k3, k5 = magic_formula_inverse_series(*curve_medians(priors))
        return cls(
            prior=prior,
            noise_scales=(steer, priors.kinematic_noise_median),
            roll_gain=1.0 + G * roll,
            force_limit=PEAK_SHARE * priors.mu_y_prior(surface)[0],
            quintic_ratio=k5 / k3**2,
            rear_nodes=rear_nodes(priors.c_y_median),
        )

    def init(self) -> LateralState:
        """The state before any block: the prior."""
        dtype = self.prior.mean.dtype

        def value(x, shape=()):
            return device_array(np.full(shape, x, dtype))

        return LateralState(
            mean=self.prior.mean,
            cov=self.prior.cov,
            steering=EquationMoments.zeros(9, dtype),
            kinematic=EquationMoments.zeros(8, dtype, lead=(len(self.rear_nodes),)),
            batches_30s=value(0.0, 2),
            steering_vif=value(1.0),
            kinematic_vif=value(1.0),
            time_s=value(0.0),
            n_samples=value(0.0),
            n_skipped=value(0.0),
            converged=device_array(np.True_),
        )

    def coefficients(
        self, theta: Float[Array, " p"], blocks: LateralBlocks
    ) -> tuple[Float[Array, "9"], Float[Array, "8"]]:
        """The two equations' coefficients c_s, c_k at ``theta``
        (:mod:`.lateral_statistics`)."""
        p = dict(NULL_VALUES)
        for i, name in enumerate(self.prior.names):
            p[name] = theta[i] if name in ("steering_offset", "ay_offset") else jnp.exp(theta[i])
        u, v = 1.0 / p["c_y_front"], 1.0 / p["c_y_rear"]
        cubic_f = p["curve_cubic_front"]
        cubic_r = p.get("curve_cubic_rear", cubic_f)
        quintic_f, quintic_r = self.quintic_ratio * cubic_f**2, self.quintic_ratio * cubic_r**2
        ratio = 1.0 if blocks.road_wheel else p["steering_ratio"]
        gain = 1.0 + G * p["roll_gradient"]
        b = p["ay_offset"]
        lf = blocks.cog_to_front_axle_m
        lr = blocks.wheelbase_m - lf
        inertia = p["yaw_inertia_factor"] * blocks.yaw_inertia_kgm2 / (blocks.mass_kg * G)
        one = jnp.ones((), theta.dtype)
        steering = jnp.stack(
            [
                one / ratio,
                -p["steering_offset"] / ratio + (u - v) * b / (gain * G),
                -(u - v) / (gain * G),
                -inertia * (u / lr + v / lf),
                -one,
                -cubic_f * u,
                cubic_r * v,
                -quintic_f * u,
                quintic_r * v,
            ]
        )
        kinematic = jnp.stack(
            [
                one, -gain, -b, v / G, -v * b / G, -gain * v * inertia / lf,
                gain * v * cubic_r, gain * v * quintic_r,
            ]
        )  # fmt: skip
        return steering, kinematic

    def kinematic_at(
        self, theta: Float[Array, " p"], kinematic: EquationMoments
    ) -> EquationMoments:
        """The kinematic moments at ``theta``'s rear stiffness, from those at the nodes."""
        return kinematic.mixed(node_weights(theta[1], self.rear_nodes))

    def _vifs(self, theta, steering: EquationMoments, kinematic: EquationMoments, blocks):
        kinematic = self.kinematic_at(theta, kinematic)
        width = blocks.speed.shape[1]
        sizes = jnp.asarray([CHUNK, width, 2 * width], theta.dtype)
        c_s, c_k = self.coefficients(theta, blocks)
        return inflation(steering, c_s, sizes), inflation(kinematic, c_k, sizes)

    def objective(
        self,
        theta: Float[Array, " p"],
        steering: EquationMoments,
        kinematic: EquationMoments,
        vifs: tuple,
        blocks: LateralBlocks,
    ) -> Float[Array, ""]:
        """The negative log-posterior at ``theta`` (module docstring), up to a constant."""
        c_s, c_k = self.coefficients(theta, blocks)
        kinematic = self.kinematic_at(theta, kinematic)
        nu = NOISE_PSEUDO_SAMPLES
        total = 0.0
        for moments, c, vif, scale in zip(
            (steering, kinematic), (c_s, c_k), vifs, self.noise_scales, strict=True
        ):
            rss = c @ moments.gram @ c
            total = total + 0.5 * (nu + moments.count / vif) * jnp.log(nu * scale**2 + rss / vif)
        d = theta - self.prior.mean
        return total + 0.5 * d @ self.prior.precision @ d

    def _gauss_newton(self, theta, steering, kinematic, vifs, blocks) -> Float[Array, "p p"]:
        """The data's Fisher information at ``theta``: each equation's Jᵀ (Σ z zᵀ) J over its
        noise variance (the inverse-gamma posterior's mean) and VIF, J = ∂c/∂θ."""
        jac_s, jac_k = jax.jacfwd(lambda t: self.coefficients(t, blocks))(theta)
        c_s, c_k = self.coefficients(theta, blocks)
        kinematic = self.kinematic_at(theta, kinematic)
        nu = NOISE_PSEUDO_SAMPLES
        total = 0.0
        for moments, c, jac, vif, scale in zip(
            (steering, kinematic), (c_s, c_k), (jac_s, jac_k), vifs, self.noise_scales, strict=True
        ):
            rss = c @ moments.gram @ c
            precision = (nu + moments.count / vif) / (nu * scale**2 + rss / vif) / vif
            total = total + precision * jac.T @ moments.gram @ jac
        return total

    def update(
        self, state: LateralState, block: BlockMoments, time_s, skipped, blocks: LateralBlocks
    ) -> LateralState:
        """One block: its moments added to the faded sums, Newton steps from the last mode to
        the new one, the Laplace covariance there (module docstring)."""
        elapsed = jnp.maximum(time_s - state.time_s, 0.0)
        fade = jnp.exp(-elapsed / self.memory_s)
        steering = state.steering.scaled(fade).plus(block.steering)
        kinematic = state.kinematic.scaled(fade).plus(block.kinematic)
        vifs = self._vifs(state.mean, steering, kinematic, blocks)

        def f(theta):
            return self.objective(theta, steering, kinematic, vifs, blocks)

        scales = jnp.asarray(_STEP_SCALES, state.mean.dtype)
        prior_precision = self.prior.precision

        def newton(carry):
            i, theta, _ = carry
            precision = prior_precision + self._gauss_newton(
                theta, steering, kinematic, vifs, blocks
            )
            step = jnp.linalg.solve(precision, jax.grad(f)(theta))
            tries = theta[None, :] - scales[:, None] * step[None, :]
            best = tries[jnp.argmin(jax.vmap(f)(tries))]
            # The step's length in posterior sds (the precision's diagonal, a lower bound).
            moved = jnp.max(jnp.abs(best - theta) * jnp.sqrt(jnp.diag(precision)))
            return i + 1, best, moved

        def going(carry):
            i, _, moved = carry
            return (i < self.newton_steps) & (moved > NEWTON_TOLERANCE)

        start = (jnp.zeros((), jnp.int32), state.mean, jnp.asarray(jnp.inf, state.mean.dtype))
        _, mode, moved = jax.lax.while_loop(going, newton, start)
        vifs = self._vifs(mode, steering, kinematic, blocks)
        exact = jax.hessian(lambda t: self.objective(t, steering, kinematic, vifs, blocks))(mode)
        root = jnp.linalg.cholesky(0.5 * (exact + exact.T))
        # The exact curvature where it is positive definite (the batch fit's Laplace); the
        # Fisher information where a mode is not yet reached (its Cholesky factor is NaN).
        root = jax.lax.cond(
            jnp.all(jnp.isfinite(root)),
            lambda: root,
            lambda: jnp.linalg.cholesky(
                prior_precision + self._gauss_newton(mode, steering, kinematic, vifs, blocks)
            ),
        )
        identity = jnp.eye(mode.shape[0], dtype=mode.dtype)
        counted = jnp.stack([block.steering.batches[1], block.kinematic.batches[0, 1]])
        return LateralState(
            mean=mode,
            cov=jax.scipy.linalg.cho_solve((root, True), identity),
            steering=steering,
            kinematic=kinematic,
            batches_30s=state.batches_30s + counted,
            steering_vif=vifs[0],
            kinematic_vif=vifs[1],
            time_s=jnp.maximum(time_s, state.time_s),
            n_samples=state.n_samples + block.steering.count,
            n_skipped=state.n_skipped + skipped,
            converged=moved <= NEWTON_TOLERANCE,
        )

    def run(
        self, state: LateralState, blocks: LateralBlocks
    ) -> tuple[LateralState, LateralTrajectory]:
        """Every block's moments at once, then :meth:`update` scanned over them; the last state
        and each block's moments of log c_y."""
        moments = block_moments(blocks, self.roll_gain, self.force_limit, self.rear_nodes)
        rows = jnp.asarray([0, 1])

        def step(carry, i):
            new = self.update(
                carry, moments.block(i), blocks.time_s[i], blocks.n_skipped[i], blocks
            )
            out = (new.time_s, new.mean[rows], new.cov[rows[:, None], rows[None, :]])
            return new, (*out, new.vif_settled())

        last, (time_s, mean, cov, settled) = jax.lax.scan(step, state, jnp.arange(blocks.n_blocks))
        return last, LateralTrajectory(
            time_s=time_s, log_c_y_mean=mean, log_c_y_cov=cov, vif_settled=settled
        )

    def result(self, state: LateralState) -> OnlineLateral:
        """The estimate of a state (readiness included, module docstring)."""
        return OnlineLateral(
            mean=state.mean,
            cov=state.cov,
            names=self.prior.names,
            time_s=state.time_s,
            prior_log_c_y_mean=device_array(np.asarray(self.prior.mean)[0]),
            prior_log_c_y_sd=device_array(np.sqrt(np.asarray(self.prior.cov)[0, 0])),
            contraction=K_CONTRACTION,
            n_samples=state.n_samples,
            n_skipped_longitudinal=state.n_skipped,
            steering_vif=state.steering_vif,
            kinematic_vif=state.kinematic_vif,
            vif_settled=state.vif_settled(),
            converged=state.converged,
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
) -> LateralRun:
    """Run the lateral estimator from the batch priors over a drive's blocks (the command's path).

    Parameters
    ----------
    blocks : LateralBlocks
        From :func:`~.lateral_blocks.lateral_blocks`.
    priors : LateralPriors, optional
    surface : str
        Road surface (the batch model's priors; the linear range does not read μ_y).

    Returns
    -------
    LateralRun
        The estimate after the last block and each block's c_y moments; its ``to_dict()`` is
        the lateral part of ``tyrebayes online --json``.

    Examples
    --------
    >>> from tyrebayes import cornering_observations, lateral_blocks, load_vehicle
    >>> from tyrebayes.simulate.cornering import simulate_cornering
    >>> vehicle = load_vehicle("compact_fwd")
    >>> frame, _ = simulate_cornering(vehicle, duration_s=300.0, seed=3)
    >>> blocks = lateral_blocks(cornering_observations(frame, vehicle))
    >>> blocks.n_blocks
    10
    >>> online_lateral(blocks).to_dict()["lateral"]["ready"]
    True
    """
    estimator = OnlineLateralEstimator.create(
        priors=priors, surface=surface, steering_ratio=float(blocks.steering_ratio)
    )
    state, parts = estimator.init(), []
    state_structure = jax.tree.structure(state)
    for start in range(0, blocks.n_blocks, RUN_BLOCKS):
        # A stored program reads and returns NumPy arrays: the state stays in NumPy between
        # parts, and becomes JAX arrays (what the modules hold) once, at the end.
        leaves, part = _stored_run(estimator, state, blocks.part(start, RUN_BLOCKS))
        state = jax.tree.unflatten(state_structure, leaves)
        parts.append(part)
    state = jax.tree.map(device_array, state)
    trajectory = LateralTrajectory(
        *(device_array(np.concatenate(x)[: blocks.n_blocks]) for x in zip(*parts, strict=True))
    )
    return LateralRun(estimate=estimator.result(state), trajectory=trajectory)


@jax.jit
def _run_leaves(
    estimator: OnlineLateralEstimator, state: LateralState, blocks: LateralBlocks
) -> tuple[list, tuple]:
    """:meth:`OnlineLateralEstimator.run` with its results as plain containers of arrays (what a
    stored program returns): the last state's leaves and the trajectory's fields."""
    last, trajectory = estimator.run(state, blocks)
    fields = (trajectory.time_s, trajectory.log_c_y_mean, trajectory.log_c_y_cov)
    return jax.tree.leaves(last), (*fields, trajectory.vif_settled)


#: :func:`_run_leaves` with its traced program kept on disk beside JAX's compilation cache
#: (:func:`~tyrebayes.internal.stored_program.stored_program`): a fleet worker that dropped its
#: compiled programs, or a new process, loads it instead of tracing it again. The estimator's
#: settings and the blocks' shape are in the arguments' structure, which names the file.
_stored_run = stored_program(_run_leaves, ("online-lateral-run",))


__all__ = [
    "LINEAR_SITES",
    "MEMORY_S",
    "NEWTON_STEPS",
    "NEWTON_TOLERANCE",
    "NOISE_PSEUDO_SAMPLES",
    "RUN_BLOCKS",
    "OnlineLateralEstimator",
    "linear_sites",
    "online_lateral",
    "run_online_lateral",
]

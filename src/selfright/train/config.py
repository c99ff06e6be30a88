"""Typed, frozen configuration of the training stack: reward weights, domain randomisation,
training episodes, networks, PPO and distillation.

The defaults are tuned for CPU training with 64–256 envs on a few cores (see ``PPOConfig``).
``TrainConfig.to_rsl_rl`` turns them into the plain dict ``rsl_rl`` runners read.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from selfright.config import RandomizationConfig, RewardConfig
from selfright.policies.level_stance import LevelStance

__all__ = [
    "Context", "Role", "RewardConfig", "RandomizationConfig", "EpisodeConfig", "PolicyConfig",
    "PPOConfig", "DistillationConfig", "ValidationConfig", "TrainConfig",
]

Context = Literal["flat", "rough", "incline"]
"""Training contexts (seed §V): flat plane, rough level ground, 20° smooth slope."""
Role = Literal["teacher", "student", "student-ppo"]
"""Teacher: PPO on privileged observations. Student: distilled onto sensor-only observations.
Student-ppo: PPO on a distilled student's sensor-only observations, its critic privileged
(``selfright.train.student_ppo``)."""


@dataclass(frozen=True, kw_only=True)
class EpisodeConfig:
    """Training episodes (evaluation episodes are defined by ``GoalConfig``)."""

    episode_s: float = 10.0
    """Training episode length after settling (s): 500 control steps at 50 Hz."""
    off_tile_is_timeout: bool = True
    """Leaving the tile ends a training episode as a time-out (PPO bootstraps the value), not
    as a terminal state. A robot lying on the ground earns a negative reward per step under
    Table I (height, collision and orientation terms), so a terminal state worth 0 pays it to
    end the episode: on the 20° incline, where rolling 3 m downhill off the tile is easy, the
    teachers learned to do exactly that (28 of the 44 failures in 64 episodes on ``--grid incline``
    of the `incline` student shipped until 2026-11-23 left the tile). The tile's edge is an artefact of simulating a finite
    patch of an unbounded slope; the benchmark still counts leaving it as a failure."""
    prepare_starts: bool = True
    """Draw and settle each slot's next episode start ahead of time, in one batched rollout
    for every slot without one, instead of settling the 1–3 episodes that end at a control step
    on their own (2 s of physics on 1–3 threads while the rest idle). Same fall protocol,
    same distribution of starts; the random stream differs from ``False``. A slot's start
    waits at most one episode: a curriculum level change since it was drawn discards it;
    replayed falls join at the next batch."""
    terminate_on_success: bool = False
    """End the episode when the goal hold completes; off = keep holding until the time-out."""
    success_is_timeout: bool = False
    """With ``terminate_on_success``: end it as a time-out (PPO bootstraps the value of the
    standing state) instead of a terminal state worth 0, which would charge a policy for
    succeeding, since Table I pays a standing robot about 10 per second. The episode then
    stops where the benchmark stops scoring it, and the steps after the hold no longer train
    the policy (on them Table I's feet term pulls every run into a crouch under the goal
    bar: docs/training.md)."""
    terminate_low_stance_s: float = 0.0
    """End the episode as a terminal state (value 0) once the robot has stood upright on four
    feet with its trunk under the goal bar for this long without a break (s); 0 = off. The
    reward stays Table I term for term, but a terminal end forfeits the ~10 per second Table I
    pays a robot standing on four feet, so a crouch under the bar (where every Table I run
    drifts: docs/training.md) is no longer worth as much as a stance above it. Like the
    goal-set term, this brings the goal bar into training, so model cards flag it. A robot
    passing through a crouch on its way up is spared by the grace time."""
    low_stance_leaky: bool = False
    """With ``terminate_low_stance_s``: count a stance on three or four feet under the bar, let
    other steps outside the goal set only take one step off the count, and clear it in the
    goal set. Off, a single step with a foot lifted or above the bar clears the count, which a
    robot creeping downhill on the incline does all the time (docs/training.md)."""
    low_stance_over_feet_m: float | None = None
    """With ``terminate_low_stance_s``: a stance is low when the trunk is under this height (m)
    above the mean ground under the feet, not under the goal bar above the ground beneath the
    trunk (``None``). On rough tiles the goal bar reads the bump or trough beneath the trunk, so
    the bar-based rule also ends proper stances (it ended 50–66 % of a rough teacher's episodes:
    docs/training.md); measured over the feet it ends only crouches, and a threshold above the
    bar asks for the taller stance that clears bumps. The goal set still clears the count."""
    terminate_on_refall: bool = False
    """End the episode as a terminal state at a re-fall (the up axis tips more than
    ``RewardConfig.refall_tilt_deg`` from vertical after the robot has been upright: roll and
    pitch each within the goal set's 30°). Off by default. A terminal state is worth 0 and a
    robot lying on the ground earns less than that under Table I, so pair it with a
    ``RewardConfig.refall`` penalty larger than the value of lying on."""
    replay_failed: float = 0.0
    """Share of new training episodes that replay the start of a recent failed one (the same
    fall-protocol draw on the same tile: position, orientation, joints; fresh randomisation
    factors), 0 = off. Failed = less than half of the episode's last ``curriculum_window_s``
    in the goal set. Every start is still a draw of the seed's fall protocol; replay only
    re-weights them towards those the policy does not yet get up from (the rare postures of
    the flat plateau). Up to ``num_envs`` failed starts are kept, oldest replayed first."""
    restart_stuck: float = 0.0
    """Share of new training episodes that start, with no new fall, from the final state of a
    recent episode that ended outside the goal set (its tile, randomisation factors and
    state, the clock reset), 0 = off. The flat plateau's failures are postures the policy
    stalls in (sitting on the rear legs: docs/training.md); this puts them in the batch as
    starts. Unlike ``replay_failed`` these starts are not draws of the seed's fall protocol.
    Up to ``num_envs`` end states are kept; each is used once, picked at random. Under Table
    I it sped the flat teacher's drift into the crouch (docs/training.md)."""
    restart_tilted_only: bool = False
    """With ``restart_stuck``: keep only end states tilted past the goal set's roll/pitch
    limit (lying on the back or side), not upright ones such as a crouch under the bar."""
    restart_arrivals: float = 0.0
    """Share of new training episodes that start at a recorded *arrival* (0 = off): the state of
    a recent training episode at the first step its trunk came within ``arrival_tilt_deg`` of
    upright, with its tile, randomisation factors, last action and the student's history at
    that step, the clock reset. The incline get-ups arrive upright in a fast flip (median
    11.7 rad/s, no foot down) and most failures fall over again in the next second; these
    starts put more of that second into the batch. Each arrival is used once. Not the seed's
    protocol; validation and ``selfright evaluate`` never use it."""
    arrival_tilt_deg: float = 45.0
    """With ``restart_arrivals``: the tilt from upright (deg) that counts as arriving."""
    stand_start: float = 0.0
    """Share of fresh training episodes that start standing instead of with the seed's fall
    (0 = off): trunk square to the ground under it at a random heading and spot of the spawn
    square, within ``stand_start_tilt_deg``, joints within ``stand_start_joint_noise_rad`` of
    the ``--action-reference`` pose (the A1's stand pose for ``current``), a random trunk
    velocity, the clock where a settle ends (``selfright.train.stand_starts``). The incline
    policies get up and then re-fall; these starts put "upright with momentum" into the batch.
    Not the seed's protocol; validation and ``selfright evaluate`` never use it."""
    stand_start_tilt_deg: float = 15.0
    """With ``stand_start``: largest tilt away from square to the ground (deg)."""
    stand_start_joint_noise_rad: float = 0.15
    """With ``stand_start``: largest offset of each joint from the pose (rad)."""
    stand_start_lin_vel_mps: float = 0.5
    """With ``stand_start``: largest trunk linear velocity per axis (m/s)."""
    stand_start_ang_vel_rps: float = 1.0
    """With ``stand_start``: largest trunk angular velocity per axis (rad/s)."""
    upright_policy: str | None = None
    """A frozen teacher checkpoint that acts in every training step where the trunk is within
    ``upright_tilt_deg`` of upright, replacing the trained policy's action there: an escape
    specialist then trains inside the composite it will serve in
    (``selfright.train.upright_override``). None = the trained policy acts throughout."""
    tilted_policy: str | None = None
    """The other way round: a frozen (escape) teacher checkpoint that acts in every training
    step where the trunk is tilted more than ``upright_tilt_deg``, so the trained policy (a
    teacher, or a student of the stand-up teacher) acts only on the states that escape hands
    over. Not with ``upright_policy``."""
    upright_tilt_deg: float = 45.0
    """With ``upright_policy`` or ``tilted_policy``: the hand-over tilt (deg)."""
    upright_masked: bool = False
    """With ``upright_policy`` or ``tilted_policy`` on a teacher: leave the overridden steps out of PPO's policy gradient
    (advantages normalised over the steps the trained policy acted in, zero elsewhere, scaled by
    1 / their share; ``selfright.train.override_mask``). The critic still learns from every step."""
    curriculum: bool = False
    """Terrain curriculum: each env slot holds a level (the context's tiles from easy to hard:
    rough extents ascending, incline slopes ``incline_curriculum_deg``), starts at the
    easiest, moves up after an episode whose last ``curriculum_window_s`` were mostly in the
    goal set and down after one that ended with none (or off the tile)."""
    incline_curriculum_deg: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0)
    """Slopes of the ``incline`` context's curriculum levels (deg); the last is the context's 20°."""
    incline_slopes_deg: tuple[float, ...] | None = None
    """Without ``curriculum``: the slopes (deg) of the ``incline`` context's training tiles, one
    drawn uniformly per episode; ``None`` = the context's 20° alone. Training on steeper slopes
    than the benchmark's (e.g. ``20 22.5 25``) asks the policy for a margin: a stand-up that
    does not roll over downhill at 25° has room to spare at 20°. Validation and ``selfright
    evaluate`` always use the benchmark's 20° grid; model cards record the option."""
    curriculum_window_s: float = 1.0
    """Final stretch of an episode that decides promotion (s)."""
    rough_variants: int = 8
    """Tiles of the ``rough`` context, roughness extents evenly spaced up to ``rough_max_extent_m``;
    each is one fixed noise draw. With 8 a teacher that reads a height scan learns those tiles:
    ``rough-dc-teacher`` scores 74 % on its level-12 training tile and 58 % on fresh ones
    (``scripts/train_tiles.py``); 64 lifted it from 80.7 to 86.0 % on the benchmark's (fresh)
    tiles, seeds 0–7 (docs/training.md, *Sixty-four training tiles for the rough teacher*).
    The default stays 8 so the shipped runs' commands reproduce; pass 64 for new rough runs."""
    tile_size_m: float | None = None
    """Side of the training tiles (m); ``None`` = the benchmark's (``TerrainConfig.tile_size_m``,
    8 m). Robots are still dropped in the same central square; a larger tile lets an episode
    that rolls away keep paying Table I's lying and drift penalties instead of ending at the
    edge (the edge of a finite patch of an unbounded slope is an artefact). Validation and
    ``selfright evaluate`` always use the benchmark's tile."""
    wall_gap_ratios: tuple[float, ...] = ()
    """Side-wall gaps (body lengths, the benchmark's ``--wall-gap-ratio``) to train between, a
    further factor of the seed: every training tile is built once open and once per gap, and
    each episode draws one of these worlds uniformly (with walls the robot is dropped midway
    between them, as in the benchmark). Empty = open ground only. The teacher observation has
    no wall feature; the walls are felt through the body's contacts."""
    ground_timeconsts_s: tuple[float, ...] = ()
    """Softer ground contacts (s, the benchmark's ``--ground-timeconst``) to train on besides the
    benchmark's 0.02 s: every world above is built once more per time constant, drawn
    uniformly with the rest. Empty = the benchmark's ground only."""
    rough_max_extent_m: float = 0.35
    """Largest peak-to-peak roughness extent of the ``rough`` context (m). 0.35 m covers
    ``--grid rough`` (levels 4, 8, 12: 0.105, 0.21, 0.32 m) with a margin, so the policy is
    judged on roughness it trained on."""
    rough_min_extent_m: float = 0.0
    """The ``rough`` context's extents are evenly spaced over (``rough_min_extent_m``,
    ``rough_max_extent_m``]: the tiles lie at ``min + (max - min) · k / rough_variants``,
    k = 1 … ``rough_variants``. 0 (the default, the shipped runs' tiles) spreads them from
    the flat plane up; a larger value gives the rough ground's hardest levels a larger share
    of the training episodes (e.g. 0.15 puts every tile between the grid's levels 6 and 13)."""


@dataclass(frozen=True, kw_only=True)
class PolicyConfig:
    """Actor and critic networks (rsl_rl ``MLPModel``)."""

    hidden_dims: tuple[int, ...] = (256, 128, 64)
    """Hidden layer widths of actor and critic MLPs (units)."""
    activation: str = "elu"
    """Hidden activation (an ``rsl_rl`` activation name)."""
    obs_normalization: bool = True
    """Running mean/std normalisation of the inputs (stats are exported with the actor)."""
    init_std: float = 0.5
    """Initial standard deviation of the Gaussian action noise (action units). 0.5 gives
    0.25 rad of target jitter with the 0.5 rad action scale, the exploration legged_gym's A1
    setup uses; 1.0 made the target random-walk so hard that standing was never found."""
    state_dependent_std: bool = False
    """Teacher only: the actor's last layer also outputs the log standard deviation, so the
    exploration noise depends on the state (rsl_rl ``HeteroscedasticGaussianDistribution``)
    instead of being one learned vector. ``--init-from`` a checkpoint with a state-independent
    std starts with the std head's weights at zero and its bias at the source's log std: the
    same stochastic policy. The deployed (mean) actor is the first half of the last layer."""
    max_std: float | None = None
    """PPO roles: upper bound on each joint's action std (action units), applied where the
    noise is drawn (rsl_rl's ``std_range`` clamp), so a learned std above it acts as the bound
    and stops moving; ``None`` = no bound. For going on from a trained actor with less
    exploration noise (a resumed run takes the bound given on its command line). The deployed
    actor acts with its mean and is unaffected."""

    def __post_init__(self) -> None:
        if self.max_std is not None and not self.max_std > 0:
            raise ValueError(f"policy.max_std must be positive, got {self.max_std}")


@dataclass(frozen=True, kw_only=True)
class PPOConfig:
    """PPO hyper-parameters for CPU training with 64–256 envs.

    One iteration collects ``num_envs × steps_per_env`` transitions (1536 with 64 envs),
    split into ``num_mini_batches`` minibatches over ``num_learning_epochs`` epochs, so the
    update costs about as much as the collection on a CPU.
    """

    steps_per_env: int = 24
    """Transitions collected per env per iteration (control steps)."""
    num_learning_epochs: int = 5
    """Passes over each rollout."""
    num_mini_batches: int = 4
    """Minibatches per epoch."""
    clip_param: float = 0.2
    """PPO ratio clip (dimensionless)."""
    gamma: float = 0.99
    """Discount per control step (dimensionless)."""
    lam: float = 0.95
    """GAE λ (dimensionless)."""
    value_loss_coef: float = 1.0
    """Weight of the value loss (dimensionless)."""
    entropy_coef: float = 0.005
    """Weight of the entropy bonus (dimensionless); 0.01 let the action noise grow steadily
    (std 1.0 → 1.3 in 2M steps) without finding the standing reward."""
    learning_rate: float = 1e-3
    """Initial Adam learning rate, adapted to hit ``desired_kl`` (1/update)."""
    schedule: Literal["adaptive", "fixed"] = "adaptive"
    """Learning-rate schedule."""
    desired_kl: float = 0.01
    """Target KL divergence per update for the adaptive schedule (nats)."""
    max_grad_norm: float = 1.0
    """Gradient-norm clip (dimensionless)."""
    symmetry_augmentation: bool = False
    """Append the left-right mirror image of every transition to each minibatch (rsl_rl's
    ``Symmetry`` extension with ``selfright.train.symmetry``); the reward is untouched."""
    mirror_loss_coef: float = 0.0
    """Weight of rsl_rl's mirror loss (MSE between the policy's action on mirrored
    observations and its mirrored action); 0 = off."""
    critic_warmup_iterations: int = 0
    """The first N iterations of a new run update only the critic (the actor, its action std
    included, is frozen), so that a critic taken from another policy (``--role student-ppo``)
    fits the actor it now judges before PPO moves the actor; 0 = off. The adaptive schedule
    does not move the learning rate during the warm-up (the actor's KL is 0), so the actor's
    first update runs at ``learning_rate``: at the default 1e-3 that first step took a
    distilled incline student's training in-goal share from 0.37 to 0.08 (thirty-second
    session); start such forks at 1e-4."""


@dataclass(frozen=True, kw_only=True)
class DistillationConfig:
    """Student distillation (rsl_rl ``Distillation``: behaviour cloning on the student's rollouts)."""

    steps_per_env: int = 24
    """Transitions collected per env per iteration (control steps)."""
    num_learning_epochs: int = 2
    """Passes over each rollout."""
    gradient_length: int = 6
    """Env steps (of all envs) accumulated per gradient step; should divide
    ``steps_per_env × epochs``. 2 epochs of 24 steps in groups of 6 = 8 Adam steps per
    iteration (1 epoch of 2 × 12 gave 2: too few for the MLP to follow the teacher)."""
    learning_rate: float = 1e-3
    """Adam learning rate (1/update)."""
    max_grad_norm: float = 1.0
    """Gradient-norm clip (dimensionless)."""
    loss_type: Literal["mse", "huber"] = "mse"
    """Behaviour-cloning loss between student and teacher mean actions."""
    student_history: int = 1
    """Frames of the ``student`` observation the student reads, stacked oldest first (1 = the
    current one only). The issue allows a short history: on the incline a lying robot cannot
    tell the slope from one IMU reading, while a few frames show which way it slides.
    Deployment stacks frames the same way (``selfright.policies.history``)."""
    student_gru: int = 0
    """Hidden size of a GRU between the student's input and its MLP (rsl_rl ``RNNModel``);
    0 = a feed-forward student. A recurrent student remembers the whole episode instead of a
    fixed window; it is trained by truncated backpropagation through ``gradient_length``
    steps and deployed with its hidden state kept per env slot, reset at each episode's start
    (``selfright.policies.recurrent``)."""
    velocity_estimator: tuple[int, ...] = ()
    """Hidden widths of a trunk-velocity estimator inside the student
    (``selfright.train.velocity_estimator``): an MLP from the student's normalised input to the
    body-frame trunk linear velocity (3, m/s), regressed on the teacher observation's true
    velocity on every rollout, whose estimate the student's MLP reads beside its input. It ships
    inside the policy (deployment needs only the student's observations). () = no estimator."""
    estimator_learning_rate: float = 1e-3
    """Adam learning rate of the velocity estimator (1/update; 2 epochs × 4 minibatches per rollout)."""
    fallback_teacher: str | None = None
    """A second teacher checkpoint that labels some states instead of the first
    (``selfright.train.fallback_teacher``): those where the robot has stalled under the first
    (still for ``stall_s`` while tilted more than 30° or under the goal bar, then for
    ``fallback_s``), or, with ``fallback_tilt_deg``, every state tilted over. It needs the first
    teacher's network; if it was trained around the other fixed action reference (``stand`` /
    ``tall``), its labels are converted to the student's. None = one teacher."""
    fallback_tilt_deg: float = 0.0
    """With ``fallback_teacher``: it labels every state whose trunk is tilted more than this
    from upright (deg), the first teacher the rest; a rule of the current state alone
    (``selfright.policies.stall.TiltSwitch``). 0 = the stall rule."""
    rough_teacher: str | None = None
    """With ``fallback_teacher``: a third teacher checkpoint that labels, instead of the first,
    the states the first would label where the teacher's height scan spreads over
    ``rough_scan_std_m`` (rough ground; ``selfright.policies.stall.ScanSwitch``). The rough
    context's composite of the `tall` flat teacher (level 4) and a teacher trained on rough
    ground (levels 8 and 12) beats either alone (docs/training.md). It needs the first
    teacher's network; labels convert between ``stand`` / ``tall`` as the fallback's do."""
    rough_scan_std_m: float = 0.027
    """With ``rough_teacher``: the height scan's standard deviation (m) above which it labels."""
    fallback_s: float = 2.0
    """How long the fallback teacher labels after a stall (s)."""
    stall_s: float = 0.5
    """How long the robot must have been still before the fallback teacher labels (s)."""
    student_init_std: float = 0.1
    """Action noise of the student while it collects its own rollouts (action units)."""
    ema_decay: float = 0.0
    """Per-iteration decay of an exponential moving average of the student's weights
    (``selfright.train.ema``), saved in every checkpoint and deployed instead of the raw
    weights; it spans about 1 / (1 − decay) iterations. 0 = off (the raw weights deploy)."""
    stance_ramp_s: float = 0.0
    """> 0: distil a fixed stance into a student (``selfright.train.stance_teacher``). The
    ``--teacher`` is then a feed-forward *student* (run or checkpoint) whose own actions are
    the labels, blended over this long (s) to ``stance_pose`` once the trunk has been upright
    within ``stance_tilt_deg`` for ``stance_delay_s``; the new student starts as a copy of it
    (or of ``--init-from``). 0 with a student ``--teacher``: the labels are its actions as they
    are. Either way the labelling student reads the exact sensors, whatever the sensor noise.
    **Not** the seed's recipe (its labels add a hand-set stance; model cards say so). 0 = off."""
    stance_delay_s: float = 2.0
    """With ``stance_ramp_s``: how long the trunk must have been upright before the blend starts (s)."""
    stance_tilt_deg: float = 15.0
    """With ``stance_ramp_s``: how close to upright counts as upright (deg, projected gravity)."""
    stance_pose: tuple[float, float, float] = (0.0, 0.46, -0.92)
    """With ``stance_ramp_s``: the stance's hip, thigh and knee angles (rad) on every leg: the
    knee at its limit and the foot under the hip."""
    stance_weight: float = 1.0
    """With ``stance_ramp_s``: how far the labels blend, in (0, 1]: 1 = all the way to
    ``stance_pose``; 0.3 = the base student's action moved 30 % of the way there, its own
    balance corrections kept (on the 20° incline the full stance tips over; docs/training.md)."""
    stance_lean: tuple[float, float] = (0.0, 0.0)
    """With ``stance_ramp_s``: lean the stance's legs towards gravity, read from the IMU each
    step (``selfright.policies.pose_blend.gravity_lean``): the hips turn by the first gain times
    the trunk's roll, the thighs by the second times its pitch. ``0 1`` puts the feet under the
    hips in the world fore and aft: held on the 20° slope, that stance stands facing up or down
    it, where the square one tips (``python scripts/slope_stance.py --lean 0 1``). 0 0 = the
    fixed ``stance_pose``. **Not** the seed's recipe."""
    stance_level: bool = False
    """With ``stance_ramp_s``: the stance is ``stance_level_law`` instead of ``stance_pose``: leg
    lengths and lean set each step from the IMU's gravity so that, held by the servos alone, it
    stands on the 20° slope at every heading (``selfright.policies.level_stance``; ``python
    scripts/slope_stance.py --level``). **Not** the seed's recipe."""
    stance_level_law: LevelStance = field(default_factory=LevelStance)
    """With ``stance_level``: the law's leg length and gains."""
    hold_after_s: float = 0.0
    """> 0 with a student ``--teacher``: once the robot has stood still over the goal bar for this
    long (s) — trunk upright within ``stance_tilt_deg``, its height above the ground beneath it at
    least ``hold_height_m``, trunk slower than ``hold_speed_mps``, every joint slower than
    ``hold_joint_speed_rad_s``; the privileged teacher observation tells all of it — the labels are
    the action the student took the step before: keep the joint targets, stop moving
    (``selfright.train.stance_teacher``). Teaches a blind student that steps on when it already
    stands where the goal set counts it to stay there. **Not** the seed's recipe. 0 = off."""
    hold_height_m: float | None = None
    """With ``hold_after_s``: the trunk height above the ground beneath it (m) over which a still
    robot holds; None = the goal bar (``GoalConfig``: 80 % of the leg length)."""
    hold_speed_mps: float = 0.1
    """With ``hold_after_s``: how slowly the trunk must move to count as still (m/s)."""
    hold_joint_speed_rad_s: float = 1.0
    """With ``hold_after_s``: how slowly every joint must turn to count as still (rad/s); a leg in
    mid-step turns faster, so a step is not frozen with a foot in the air."""
    rescue_student: str | None = None
    """With ``stance_ramp_s``: a feed-forward student (policy name, file or run) whose actions
    label the states where the robot has lain still, tilted more than 30°, for ``stall_s``, and
    for ``rescue_s`` after (``StallSwitch`` without a height bar: what the IMU and joint speeds
    tell), instead of the base student's; converted between ``stand`` / ``tall`` references.
    Distils the evaluation-time stall rescue (``scripts/stall_rotation.py --no-below-bar``).
    **Not** the seed's recipe. None = off."""
    rescue_s: float = 1.0
    """With ``rescue_student``: how long it labels after a stall (s)."""


@dataclass(frozen=True, kw_only=True)
class ValidationConfig:
    """Benchmark evaluation of every saved checkpoint (``selfright.train.validation``). A teacher
    trained beside a frozen policy (``EpisodeConfig.upright_policy`` or ``tilted_policy``) is
    validated inside that composite, the policy it is trained to be part of. A student trained
    under ``RandomizationConfig.sensor_noise`` is validated through the same noise."""

    episodes: int = 0
    """Episodes per grid cell for each checkpoint; 0 = no validation."""
    seed: int = 1
    """Run seed of the validation episodes (not 0, the seed model cards report)."""
    grid: str | None = None
    """Named grid to validate on; default: the training context's grid (flat, rough, incline)."""
    wall_gap_ratio: float | None = None
    """Validate between side walls this many body lengths apart; ``None`` = open ground."""
    ground_timeconst_s: float | None = None
    """Validate on ground of this contact time constant (s); ``None`` = the benchmark's."""


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """Everything a training run needs beyond the benchmark configuration."""

    reward: RewardConfig = field(default_factory=RewardConfig)
    randomization: RandomizationConfig = field(default_factory=RandomizationConfig)
    episode: EpisodeConfig = field(default_factory=EpisodeConfig)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    ppo: PPOConfig = field(default_factory=PPOConfig)
    distillation: DistillationConfig = field(default_factory=DistillationConfig)
    validation: ValidationConfig = field(default_factory=ValidationConfig)
    recenter_on_init: bool = True
    """With ``--init-from``: observation features that never varied in the source run get the
    new context's mean as their normaliser mean (the rest of the statistics are kept). Without
    it such a feature is blown up: the slope angle is 0 with std 0 on the flat plane, so on the
    20° incline it enters the flat teacher's network as 0.35 rad / 0.01 (the normaliser's eps)
    = 35 standard deviations."""
    checkpoint_every_s: float = 300.0
    """Wall-clock time between checkpoints (s); one is also written at the end."""
    keep_checkpoints: int = 10
    """Most recent time-based checkpoints kept on disk; 0 = keep all."""

    def to_rsl_rl(self, role: Role, teacher_policy: PolicyConfig | None = None) -> dict[str, Any]:
        """The ``train_cfg`` dict of ``OnPolicyRunner`` (teacher, student-ppo) or ``DistillationRunner`` (student).

        ``teacher_policy`` is the network of the trained teacher being distilled, or whose critic
        a student-ppo run starts from (default: ``policy``).
        """
        pol = self.policy
        net = _mlp_cfg(pol)
        common = {"save_interval": 10**9, "logger": "tensorboard", "check_for_nan": True}
        if role in ("teacher", "student-ppo"):
            p = self.ppo
            # student-ppo: the student's network on its frames; the critic is the teacher's.
            actor_group = "teacher" if role == "teacher" else student_group(self.distillation.student_history)
            critic = dict(net) if role == "teacher" else _mlp_cfg(teacher_policy or pol)
            return {
                **common,
                "num_steps_per_env": p.steps_per_env,
                "obs_groups": {"actor": [actor_group], "critic": ["teacher"]},
                "actor": {**net, "distribution_cfg": _gaussian(pol.init_std, pol.state_dependent_std, pol.max_std)},
                "critic": critic,
                "algorithm": {
                    "class_name": "PPO",
                    "num_learning_epochs": p.num_learning_epochs,
                    "num_mini_batches": p.num_mini_batches,
                    "clip_param": p.clip_param,
                    "gamma": p.gamma,
                    "lam": p.lam,
                    "value_loss_coef": p.value_loss_coef,
                    "entropy_coef": p.entropy_coef,
                    "learning_rate": p.learning_rate,
                    "max_grad_norm": p.max_grad_norm,
                    "schedule": p.schedule,
                    "desired_kl": p.desired_kl,
                    "use_clipped_value_loss": True,
                    "symmetry_cfg": _symmetry_cfg(p),
                },
            }
        d = self.distillation
        return {
            **common,
            "num_steps_per_env": d.steps_per_env,
            "obs_groups": {"student": [student_group(d.student_history)], "teacher": ["teacher"]},
            "student": {**_student_cfg(pol, d.student_gru, d.velocity_estimator),
                        "distribution_cfg": _gaussian(d.student_init_std)},
            # The teacher acts deterministically; init_std 0 as rsl_rl's maintainers advise
            # (its trained std is loaded with the weights and never used).
            "teacher": {
                **_mlp_cfg(teacher_policy or pol),
                "distribution_cfg": _gaussian(0.0, (teacher_policy or pol).state_dependent_std),
            },
            "algorithm": {
                "class_name": "Distillation",
                "num_learning_epochs": d.num_learning_epochs,
                "gradient_length": d.gradient_length,
                "learning_rate": d.learning_rate,
                "max_grad_norm": d.max_grad_norm,
                "loss_type": d.loss_type,
            },
        }


def student_group(history: int) -> str:
    """Name of the observation group a student with ``history`` frames reads."""
    return "student" if history <= 1 else "student_history"


LABEL_GROUP = "student_exact"
"""Observation group of a student that labels another (``--teacher STUDENT``: a copy, or a
stance distillation with ``--train.distillation.stance-ramp-s``): the ``student`` observation *before* any sensor noise,
its frames stacked as that student reads them. Labels are computed from the exact state, so a
student trained under ``--train.randomization.sensor-noise`` learns what the label student does on
exact sensors, not what it does on noisy ones."""


def _symmetry_cfg(p: PPOConfig) -> dict[str, Any] | None:
    """rsl_rl's ``symmetry_cfg`` (None when neither augmentation nor mirror loss is on)."""
    if not p.symmetry_augmentation and p.mirror_loss_coef == 0.0:
        return None
    return {
        "data_augmentation_func": "selfright.train.symmetry:augment_left_right",
        "use_data_augmentation": p.symmetry_augmentation,
        "use_mirror_loss": p.mirror_loss_coef > 0.0,
        "mirror_loss_coeff": p.mirror_loss_coef,
    }


def _mlp_cfg(pol: PolicyConfig) -> dict[str, Any]:
    return {
        "class_name": "MLPModel",
        "hidden_dims": list(pol.hidden_dims),
        "activation": pol.activation,
        "obs_normalization": pol.obs_normalization,
    }


def _student_cfg(pol: PolicyConfig, gru: int, estimator: tuple[int, ...] = ()) -> dict[str, Any]:
    """The student network: the actor MLP, behind a one-layer GRU of ``gru`` units if ``gru`` > 0,
    or reading a velocity estimator of hidden widths ``estimator`` if given (not both)."""
    if estimator:  # (TrainingRun refuses both)
        return {**_mlp_cfg(pol), "class_name": "selfright.train.velocity_estimator:EstimatorMLPModel",
                "estimator_dims": list(estimator)}
    if gru <= 0:
        return _mlp_cfg(pol)
    return {**_mlp_cfg(pol), "class_name": "RNNModel", "rnn_type": "gru", "rnn_hidden_dim": gru, "rnn_num_layers": 1}


def _gaussian(init_std: float, state_dependent: bool = False, max_std: float | None = None) -> dict[str, Any]:
    bound = {} if max_std is None else {"std_range": (1e-6, float(max_std))}
    if state_dependent:
        # A std of 0 has no log: a deterministic (distilled-from) teacher's head is never used.
        return {"class_name": "HeteroscedasticGaussianDistribution", "init_std": max(init_std, 1e-3), "std_type": "log",
                **bound}
    return {"class_name": "GaussianDistribution", "init_std": init_std, "std_type": "scalar", **bound}

//! The tuning table of identification: every constant whose value was chosen on a benchmark
//! rather than derived. Each entry says what it is and why it has its value; the measurements
//! behind the choice are in `docs/experiments.md` under the anchor given.

use crate::identification::fit::Weighting;

/// Joint speed (rad/s) below which an excited joint's samples are not fitted on (the Coulomb
/// sign and stiction around velocity reversals are uncertain there), unless the robot is held
/// exactly still. Why 0.05: it leaves out the reversals without losing the slow motion that
/// shows the friction (docs/experiments.md#fit-options); on the family of truths 0.01, 0.02 and
/// 0.1 were no better across seeds (docs/experiments.md#the-least-fitted-speed-across-the-family).
pub const MIN_SPEED: f64 = 0.05;

/// Fastest rate (Hz) at which a log's states are fitted on; a faster log is fitted on every
/// `k`-th state, all of them counted in the cross-validated energies. Why 25: consecutive
/// states of a faster log carry nearly the same information (their residuals are correlated
/// over tens of milliseconds), and fitting on all of them cost identification time in
/// proportion (docs/experiments.md#fit-rate).
pub const MAX_FIT_RATE_HZ: f64 = 25.0;

/// Contiguous time blocks each log is cut into for cross-validation (its folds when there are
/// fewer than three logs). Why 5: enough held-out pieces for the structure error with blocks
/// long enough to hold whole moves (docs/experiments.md#fit-options).
pub const FOLDS: usize = 5;

/// Weighting of the samples by default: power-level (the residual variance grows with the
/// predicted active power). Why: where the residual does not grow with the power it gives
/// ordinary least squares to the printed digits; where it does, it keeps one design from
/// misplacing the standby (docs/experiments.md#power-level-weighting-as-the-fit-default).
pub const WEIGHTING: Weighting = Weighting::PowerLevel;

/// Make the chosen model physically consistent by default (loss terms refitted). Why: better
/// held-out energies under the realistic truth, neutral under the exact one
/// (docs/experiments.md#consistent-model-by-default).
pub const CONSISTENT: bool = true;

/// Fit each motor's logged power besides the arm's by default, where the logs have it. Why:
/// each joint's parameters are then seen in its own motor, the wrist's standard deviations
/// several times smaller (docs/experiments.md#motor-power).
pub const MOTOR_POWER: bool = true;

/// Largest lag (s) of the logged power behind the joints that identification searches for
/// (either sign), estimated from the logs by the power model's own fit
/// ([`crate::identification::fit::FitOptions::max_power_lag_s`]). Why 0.1: power meters and
/// drive loggers on their own clock lag by tens of milliseconds; the family of truths draws
/// 0-40 ms, and a lag of 30 ms left unmodelled cost 12-14 % of the energy of held-out motions
/// there (docs/experiments.md#power-lag-in-the-fit).
pub const MAX_POWER_LAG_S: f64 = 0.1;

/// Fraction of the mechanical energy a payload heavier than the identification logs carried
/// moves through the joints (for the part of its mass beyond theirs) that a prediction takes
/// as one standard deviation more. Losses that grow with the transmitted torque (a harmonic
/// drive's load-dependent friction, a copper coefficient fitted on small torques) cannot be
/// told from logs that never carried the load. Why 0.01: over 8 family robots identified
/// unloaded (4 x 20 s excitations each, 72 held-out predictions at 2, 4 and 5.32 kg), 0.008
/// left one robot at 50 % coverage (pooled 92 %, median |z| 0.61) and 0.01 covered 99 % with
/// every robot at 92 % or more (median |z| 0.52); without the term 79 % (1.20)
/// (docs/experiments.md#a-payload-heavier-than-the-logs-carried).
pub const UNSEEN_LOAD_LOSS: f64 = 0.01;

/// Share of a motion's time at rest (every joint slower than the least fitted speed) at which
/// its prediction takes the whole error the cross-validation pieces of one fold share
/// (`structure_fold_W`, what leaving a whole log out of the fit costs); below it, that
/// variance in proportion. A model fitted above a least speed never saw a rest: the longer a
/// motion rests, the farther it lies from the logs. Why 0.4: chosen on the family of truths
/// (seeds 1-3) as the smallest share whose pooled median |z| from the log reached the
/// calibrated band, and checked on seeds 4 and 5, which the choice did not see
/// (docs/experiments.md#the-folds-shared-error-and-the-rests-issue-30).
pub const FOLD_ERROR_REST_SHARE: f64 = 0.4;

/// Share of the drive file's Stribeck rise ([`crate::identification::model::Stribeck`]) that
/// a model's Coulomb friction takes at slow joint speeds, in its fit and its predictions; a
/// prediction adds the energy of the whole rise beyond it to its standard deviation. The logs
/// barely show the rise, and a data sheet's static friction is an estimate whose effect on the
/// motor's power depends on how the controller holds a slow joint. Why 0.5: chosen on family
/// seeds 1-3 (24 robots, 2 x 12 held-out motions each) and checked on seeds 4 and 5
/// (docs/experiments.md#the-drive-files-stribeck-law).
pub const STRIBECK_SHARE: f64 = 0.5;

/// Standard deviations by which a copper-loss coefficient must exceed zero to stay free in a
/// PMSM fit (the others are held at zero). Why 2: a coefficient within two deviations of zero
/// trades against the standby along directions the data barely see and predicts other
/// motions far off (docs/experiments.md#copper-coefficients-held-at-zero).
pub const COPPER_SIGNIFICANCE: f64 = 2.0;

/// Levenberg–Marquardt of the power fit stops when a step lowers the cost by less than this in
/// units of the residual variance (a chi-square): the parameters are then within about 0.01
/// standard deviations of the least cost (`delta^T Cov^-1 delta ~ 2 x 1e-4`). Why: a fixed
/// relative fall takes many more iterations for no change in the printed figures
/// (docs/experiments.md#levenberg-marquardt-stopping-rule).
pub const CONVERGED_CHI2: f64 = 1e-4;

/// Half-width (s) of the window in which the spline route's move weights fit each joint's
/// local slope. Why 0.1: at 10 Hz the sample and one on each side; a wider window reaches from
/// the edges of a short stand-still into the motion next to it
/// (docs/experiments.md#route-move-weights).
pub const SLOPE_HALF_WINDOW_S: f64 = 0.1;

/// Bounds of the move weights' ramp, in standard deviations of a joint's local slope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveZ {
    /// Below this the joint is taken as not seen to move (weight 0).
    pub still: f64,
    /// Above this the joint is taken as moving (weight 1); linear between.
    pub moving: f64,
}

/// The local slope's size in standard deviations below which the spline route's move weights
/// take a joint as not seen to move (encoder noise alone stays below 2 in 95 % of windows) and
/// above which as moving. Why (2, 4): chosen on the held-out benchmark over the smooth
/// `erf(z / sqrt 2)` weight (docs/experiments.md#route-move-weights); on the family of truths
/// (1.5, 3) and (3, 6) moved no pooled figure by more than 0.01
/// (docs/experiments.md#the-routes-move-and-edge-thresholds-across-the-family).
pub const MOVE_Z: MoveZ = MoveZ {
    still: 2.0,
    moving: 4.0,
};

/// Noise-normalised shift (standard deviations, weighed over all joints along the motion's
/// direction) at which a rest's edge sample counts as already moved off the rest toward the
/// motion next to it. Why 6: seven standard deviations of one joint pass for rest; on the
/// held-out benchmark 5 moved an edge sample that had not moved and 4 moved more
/// (docs/experiments.md#rest-edges); on the family of truths 5 and 7 moved no pooled figure
/// by more than 0.01 (docs/experiments.md#the-routes-move-and-edge-thresholds-across-the-family).
pub const EDGE_Z: f64 = 6.0;

/// Noise-normalised shift at which a rest's edge sample counts as moved when the `(t - t0)^3`
/// law through the motion's next two samples also places the start (stop) beyond it. Why 1:
/// the two tests agreeing catch starts a sample period off that each alone misses
/// (docs/experiments.md#rest-edges).
pub const EDGE_Z_AGREED: f64 = 1.0;

/// Least ratio of the robot's mean speed over a log's second sample interval to that over its
/// first at which a log that begins in motion counts as beginning as the robot starts from
/// rest. Why 2.5: a start from rest gives 3 (constant acceleration) to 7 (constant jerk), a
/// robot passing at constant speed 1; one already moving at `v0` and speeding up by `a`
/// reaches 2.5 only if `v0 <= a h / 6`, so starting it at rest misplaces little
/// (docs/experiments.md#starts-from-rest).
pub const START_FROM_REST_RATIO: f64 = 2.5;

/// Largest ratio of the fourth- to the eighth-order difference estimate of a joint's noise for
/// which its samples count as noise-dominated. Why 1.5: white noise gives 1, a motion the
/// sampling resolves gives far more (docs/experiments.md#encoder-noise-levels).
pub const WHITE_RATIO: f64 = 1.5;

/// Largest ratio of a joint's white-noise estimate from its differences to its scatter at rest
/// for which the route's noise levels pool the two. Why 2: the same encoder noise within the
/// rests' sampling error (a few rest samples leave the scatter uncertain by tens of percent),
/// while a joint that sticks and slips while the others move looks white with far more
/// (docs/experiments.md#encoder-noise-levels). Rests of fewer than 10 degrees of freedom allow
/// more, as their scatter's 1 % sampling error does (up to 10 for a rest of three samples;
/// docs/experiments.md#a-short-rests-noise-level).
pub const AGREED_NOISE_RATIO: f64 = 2.0;

/// Harmonics of the Fourier excitation trajectories by default. Why 5: the paper's value
/// (Liu et al. 2018), which the identification set's design keeps
/// (docs/experiments.md#excitation-harmonics).
pub const HARMONICS: usize = 5;

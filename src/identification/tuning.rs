//! The tuning table of identification: every constant whose value was chosen on a benchmark
//! rather than derived. Each entry says what it is and why it has its value; the measurements
//! behind the choice are in `docs/experiments.md` under the anchor given.

use crate::identification::fit::Weighting;

/// Joint speed (rad/s) below which an excited joint's samples are not fitted on (the Coulomb
/// sign and stiction around velocity reversals are uncertain there), unless the robot is held
/// exactly still. Why 0.05: it leaves out the reversals without losing the slow motion that
/// shows the friction (docs/experiments.md#fit-options).
pub const MIN_SPEED: f64 = 0.05;

/// Contiguous time blocks each log is cut into for cross-validation (its folds when there are
/// fewer than three logs). Why 5: enough held-out pieces for the structure error with blocks
/// long enough to hold whole moves (docs/experiments.md#fit-options).
pub const FOLDS: usize = 5;

/// Weighting of the samples by default: power-level (the residual variance grows with the
/// predicted active power). Why: where the residual does not grow with the power it gives
/// ordinary least squares to the printed digits; where it does, it keeps one design from
/// misplacing the standby (docs/experiments.md#power-level-weighting).
pub const WEIGHTING: Weighting = Weighting::PowerLevel;

/// Make the chosen model physically consistent by default (loss terms refitted). Why: better
/// held-out energies under the realistic truth, neutral under the exact one
/// (docs/experiments.md#consistent-model-by-default).
pub const CONSISTENT: bool = true;

/// Fit each motor's logged power besides the arm's by default, where the logs have it. Why:
/// each joint's parameters are then seen in its own motor, the wrist's standard deviations
/// several times smaller (docs/experiments.md#motor-power).
pub const MOTOR_POWER: bool = true;

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

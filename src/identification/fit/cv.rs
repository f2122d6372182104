//! Cross-validation: each candidate estimator fitted with one fold left out and scored on
//! it, piece by piece; the pieces' errors give the structure error.

use nalgebra::DVector;
use rayon::prelude::*;

use super::samples::{PieceId, Samples};
use super::structure::{Piece, StructureError, structure_fit};
use super::{CvScore, Estimator, Fit, Selection, Weighting, fit};
use crate::error::{Error, Result};
use crate::identification::model::PowerModel;

/// Sums over the held-out samples of one piece.
struct PieceSums {
    /// Sum of the power errors (predicted minus measured), W.
    error_w: f64,
    /// Number of samples.
    samples: usize,
    /// Sum of the gradients of the predicted power, per parameter.
    grad: Vec<f64>,
    /// Sum of the predicted active powers `|P - P0|`, W.
    active_w: f64,
}

/// Choose among `candidates` by cross-validation over the folds of the samples (see
/// [`Samples::new`]), then fit the chosen one on all samples. The other friction structure
/// (with or without gear friction) is cross-validated beside it ([`Selection::alternative`]):
/// predictions are the mean of the two structures' power, so the structure error is that of
/// the mean on the held-out pieces: their mean-power errors beyond what the chosen fold's
/// parameter covariance and residual explain (fitted by `structure_fit`: `structure_sigma_W`
/// and `structure_rel` of a piece's own, `structure_fold_W` shared by a fold's pieces), used
/// for prediction intervals. Without a cross-validated
/// alternative, the chosen structure's own pieces give it.
///
/// Errors: no candidates, or a fit that fails on all data.
pub fn select(
    template: &PowerModel,
    s: &Samples,
    candidates: &[Estimator],
    weighting: Weighting,
) -> Result<Selection> {
    if candidates.is_empty() {
        return Err(Error::InvalidInput(
            "cross-validation needs at least one estimator".into(),
        ));
    }
    let (scores, mut full) = cross_validate(template, s, candidates, weighting);
    let Some(best) = scores
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.mean_power_rms_w.total_cmp(&b.1.mean_power_rms_w))
        .map(|(i, _)| i)
    else {
        // No candidate fits every fold: the fit on all data says why (rank deficiency names
        // the parameters the data cannot reveal), or that the folds were too small.
        fit(template, s, candidates[0], weighting, &|_| true)?;
        return Err(Error::InvalidInput(
            "no estimator could be fitted with any one run left out: record more runs or longer ones"
                .into(),
        ));
    };
    let chosen = scores[best].estimator;
    let other = if chosen.fits_gear() {
        Estimator::Pmsm
    } else {
        Estimator::Gear
    };
    let mut take = |k: usize| {
        full[k]
            .take()
            .expect("each candidate's fits are taken once")
    };
    let (all, folds, own_pieces) = take(best);
    let mut f = all?;
    // The other friction structure: its cross-validated fits when it was a candidate, else
    // cross-validated now (a structure the samples cannot determine has none).
    let (other_folds, other_all) = match scores.iter().position(|c| c.estimator == other) {
        Some(k) => {
            let (all, folds, _) = take(k);
            (Ok(folds), all)
        }
        None => cv_fits(template, &s.for_estimator(other), other, weighting),
    };
    let alternative = other_all.ok().map(|a| (other, a));
    let pieces = match (&alternative, other_folds) {
        (Some(_), Ok(other_folds)) => mixture_pieces(s, (chosen, &folds), (other, &other_folds)),
        _ => own_pieces,
    };
    let StructureError {
        sigma_w,
        rel,
        fold_w,
        active_w,
    } = structure_fit(&pieces);
    (
        f.model.structure_sigma,
        f.model.structure_rel,
        f.model.structure_fold,
        f.model.structure_active,
    ) = (sigma_w, rel, fold_w, active_w);
    Ok(Selection {
        scores,
        chosen,
        fit: f,
        consistent: None,
        alternative,
        motor_power: s.motors,
    })
}

/// Each candidate's fold fits (a candidate that cannot be fitted with a fold left out is
/// dropped), scored on its held-out pieces: the scores, and per scored candidate its fit on
/// all samples, its fold fits and its pieces.
#[allow(clippy::type_complexity)]
fn cross_validate(
    template: &PowerModel,
    s: &Samples,
    candidates: &[Estimator],
    weighting: Weighting,
) -> (
    Vec<CvScore>,
    Vec<Option<(Result<Fit>, Vec<Fit>, Vec<Piece>)>>,
) {
    let mut scores = Vec::new();
    let mut full = Vec::new();
    for &est in candidates {
        let s = &*s.for_estimator(est);
        let (folds, all) = cv_fits(template, s, est, weighting);
        let Ok(folds) = folds else {
            continue;
        };
        let mut totals = Totals::default();
        let mut held: Vec<Piece> = Vec::new();
        for (k, f) in folds.iter().enumerate() {
            score_fold(s, k, (f, None), &mut totals, &mut held);
        }
        if held.is_empty() {
            continue;
        }
        scores.push(CvScore {
            estimator: est,
            mean_power_rms_w: (totals.se_mean / held.len() as f64).sqrt(),
            power_rmse_w: (totals.se_sample / totals.samples.max(1) as f64).sqrt(),
            pieces: held.len(),
        });
        full.push(Some((all, folds, held)));
    }
    (scores, full)
}

/// The held-out pieces of the prediction a model makes, the mean of the two friction
/// structures' power: fold `k`'s fits of `chosen` and `other` scored together on fold `k`.
fn mixture_pieces(
    s: &Samples,
    (chosen, folds): (Estimator, &[Fit]),
    (other, other_folds): (Estimator, &[Fit]),
) -> Vec<Piece> {
    let (sc, so) = (s.for_estimator(chosen), s.for_estimator(other));
    let mut held = Vec::new();
    for (k, (fc, fo)) in folds.iter().zip(other_folds).enumerate() {
        score_fold(
            &sc,
            k,
            (fc, Some((&so, fo))),
            &mut Totals::default(),
            &mut held,
        );
    }
    held
}

/// The fits of estimator `est` with each fold of `s` left out (an error if any fails) and
/// its fit on all samples, side by side.
fn cv_fits(
    template: &PowerModel,
    s: &Samples,
    est: Estimator,
    weighting: Weighting,
) -> (Result<Vec<Fit>>, Result<Fit>) {
    let folds = s.folds;
    let mut fits: Vec<Result<Fit>> = (0..=folds)
        .into_par_iter()
        .map(|k| {
            fit(template, s, est, weighting, &|m| {
                k == folds || s.fold[m] != k
            })
        })
        .collect();
    let all = fits.pop().expect("the fit on all samples");
    (fits.into_iter().collect(), all)
}

/// Running sums of the cross-validation scores over the folds.
#[derive(Default)]
struct Totals {
    /// Sum of the squared mean-power errors of the pieces, W^2.
    se_mean: f64,
    /// Sum of the squared power errors of the held-out samples, W^2.
    se_sample: f64,
    /// Held-out samples.
    samples: usize,
}

/// Score the fit `f` of fold `k` on the arm's power of the samples it left out: its pieces
/// appended to `held`, their errors added to `totals`. With the other friction structure's
/// fit of the same fold (and its samples), the prediction scored is the mean of the two
/// structures' power; the explained variance stays `f`'s parameter covariance, taken whole
/// (as [`PowerModel::predict`] takes it).
fn score_fold(
    s: &Samples,
    k: usize,
    (f, other): (&Fit, Option<(&Samples, &Fit)>),
    totals: &mut Totals,
    held: &mut Vec<Piece>,
) {
    let np = s.params();
    let z = DVector::from_column_slice(&f.estimate.values);
    let other = other.map(|(so, fo)| (so, DVector::from_column_slice(&fo.estimate.values)));
    let p0 = z[np - 1];
    let residual_var = f.estimate.residual_rms.powi(2);
    let mut by_piece: std::collections::BTreeMap<PieceId, PieceSums> = Default::default();
    let mut grad = vec![0.0; np];
    for m in (0..s.len()).filter(|&m| s.fold[m] == k && s.motor[m].is_none()) {
        let mut p = s.power(m, &z, Some(&mut grad));
        if let Some((so, zo)) = &other {
            p = 0.5 * (p + so.power(m, zo, None));
        }
        let e = p - s.y[m];
        totals.se_sample += e * e;
        totals.samples += 1;
        let entry = by_piece.entry(s.piece[m]).or_insert_with(|| PieceSums {
            error_w: 0.0,
            samples: 0,
            grad: vec![0.0; np],
            active_w: 0.0,
        });
        entry.error_w += e;
        entry.samples += 1;
        for (acc, g) in entry.grad.iter_mut().zip(&grad) {
            *acc += g;
        }
        entry.active_w += (p - p0).abs();
    }
    for sums in by_piece.values() {
        let c = sums.samples as f64;
        let mean = sums.error_w / c;
        let g = DVector::from_iterator(np, sums.grad.iter().map(|v| v / c));
        let param_var = (g.transpose() * &f.covariance * &g)[(0, 0)].max(0.0);
        totals.se_mean += mean * mean;
        held.push(Piece {
            error_w: mean,
            explained_w2: param_var + residual_var / c,
            active_w: sums.active_w / c,
            fold: s.folds_are_logs.then_some(k),
        });
    }
}

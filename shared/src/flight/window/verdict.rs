//! A window's own verdicts: how much load its spring left unexplained, its misfit against
//! what the model can explain, and the `Outside` reasons ([`WindowReason`]) it is judged by.
//! O(`DRIFT_TERMS`) per call.

use super::*;

impl<'a, const N: usize> WindowProblem<'a, N> {
    /// How much the window's load moved beyond its spring: the RMS over the window of the
    /// load's trend and of the drift `fit` profiled out (as a moment: amperes times the
    /// torque constant and the gear ratio), without their constant parts, over the spring's
    /// moment at the test's amplitude. The turbulence the window carried (0 in still air).
    pub fn unmodelled_moment(&self, fit: &WindowFit) -> f32 {
        let per_ampere = self.model.torque_constant() * self.model.params().gear_ratio;
        let square: f32 = self
            .load
            .trend
            .iter()
            .zip(&fit.drift)
            .enumerate()
            .skip(1)
            .map(|(j, (t, d))| {
                let m = t + per_ampere * d;
                m * m / (2 * j + 1) as f32
            })
            .sum();
        let spring = self.load.stiffness * self.model.command().amplitude;
        if spring > 0.0 {
            crate::base::math::sqrt(square) / spring
        } else {
            f32::INFINITY
        }
    }

    /// The error `error` [A²·s] over the error of a model that gives no current: how much of
    /// the window's measured current the fit leaves unexplained (0 … 1).
    pub fn misfit(&self, error: f32) -> f32 {
        if self.energy > 0.0 {
            error / self.energy
        } else {
            f32::INFINITY
        }
    }

    /// Whether the window can be trusted at all, and at the vector `k` found with the fit
    /// `error` and the friction's standard deviation `friction_std` there (the window's
    /// calibrated uncertainty; NaN if it has none): a saturated current, a manoeuvre beyond
    /// the limits' command range, a fit that leaves more than the limits' share of the
    /// current unexplained (a load the model does not play: turbulence beyond the trend, a
    /// play crossed where the model cannot follow), a window that cannot tell a wide play
    /// from none, or a friction the window cannot read (the turbulence's moment stands in
    /// for it) make it `Outside`, judged in this order. Two model runs (the play's
    /// contrast).
    pub fn judge(
        &self,
        limits: &WindowLimits,
        k: &FaultVector,
        error: f32,
        friction_std: f32,
    ) -> Result<(), WindowReason> {
        run_to_end(self.judge_stepwise(limits, k, error, friction_std))
    }

    /// [`judge`](Self::judge) in steps: its two runs stepwise
    /// ([`evaluate_stepwise`](Self::evaluate_stepwise)).
    pub async fn judge_stepwise(
        &self,
        limits: &WindowLimits,
        k: &FaultVector,
        error: f32,
        friction_std: f32,
    ) -> Result<(), WindowReason> {
        let p = self.model.params();
        if self.peak_current >= limits.saturation_share * p.max_current {
            return Err(WindowReason::CurrentSaturated {
                peak: self.peak_current,
            });
        }
        if self.command_range > limits.max_command_range {
            return Err(WindowReason::ManoeuvreTooLarge {
                range: self.command_range,
            });
        }
        let misfit = self.misfit(error);
        if misfit.is_nan() || misfit > limits.max_misfit {
            return Err(WindowReason::FitnessFloor { misfit });
        }
        // The play: the fit with no backlash against the fit with a wide one, at `k`. If
        // the two hardly differ the gear never crossed its play (the load did not reverse):
        // the window shows nothing of the backlash and the GA's value is noise. Judged
        // before the turbulence, so that a window named only for its turbulence has seen
        // the play (its evidence is sound: a flight's reading adds it, `crate::flight::fusion`).
        let with_play = |level: f32| {
            let mut genes = *k.as_array();
            if let Some(b) = genes.get_mut(1) {
                *b = level;
            }
            FaultVector::saturating(genes)
        };
        let wide = self
            .evaluate_stepwise(&with_play(PLAY_PROBE), self.load)
            .await
            .error;
        let none = self
            .evaluate_stepwise(&with_play(0.0), self.load)
            .await
            .error;
        let contrast = abs(wide - none) / error.max(f32::MIN_POSITIVE);
        if contrast.is_nan() || contrast < limits.min_play_contrast {
            return Err(WindowReason::PlayUnseen { contrast });
        }
        if friction_std.is_nan() || friction_std > limits.max_friction_std {
            return Err(WindowReason::TurbulenceTooHigh { friction_std });
        }
        Ok(())
    }
}

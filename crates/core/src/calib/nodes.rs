//! Nodes and the stretches between them, as the velocity-error-rate
//! cross-check and the discrepancy workflow's gap both use them: where
//! the nodes fall in the dwells, one walk that collects the navigated
//! velocity and the parameter columns at each, and the error model over
//! the stretch between two nodes.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Vector3};

use super::error::CalibError;
use super::prescan::dwell_at;
use super::segment::RunSegment;
use super::walk::{walk, PassContext, WindowEnd};
use crate::estimation::effect_columns::EffectTerms;
use crate::estimation::filter::{process_noise, transition};
use crate::model::{Compensator, Grade};

/// Stretches each dwell is cut into.
const STRETCHES_PER_DWELL: usize = 4;

/// Where the nodes fall: at the first and last window wholly inside each
/// dwell and at `STRETCHES_PER_DWELL` − 1 evenly spaced windows between.
struct NodeSchedule {
    window_s: f64,
    /// The dwell being crossed and how many of its windows were seen.
    inside: Option<(usize, usize)>,
}

impl NodeSchedule {
    fn new(window_s: f64) -> Self {
        NodeSchedule {
            window_s,
            inside: None,
        }
    }

    /// Called at every window's end, in order: the dwell index when this
    /// window's end is a node.
    fn node_at(&mut self, segments: &[RunSegment], t_start: f64, t_end: f64) -> Option<usize> {
        let d0 = dwell_at(segments, t_start);
        let Some(d) = d0.filter(|_| d0 == dwell_at(segments, t_end)) else {
            self.inside = None;
            return None;
        };
        let count = match self.inside {
            Some((dd, c)) if dd == d => c + 1,
            _ => 0,
        };
        self.inside = Some((d, count));
        let seg = &segments[d];
        let capacity = ((seg.t_end - seg.t_start) / self.window_s).floor().max(1.0) as usize;
        let stride = capacity.div_ceil(STRETCHES_PER_DWELL).max(1);
        let last = t_end + self.window_s > seg.t_end;
        (count == 0 || count % stride == 0 || last).then_some(d)
    }
}

/// Walks the run once, compensated with `comp`, from `c_b_n0`, with
/// nodes scheduled for windows of `window_s`: hands every window's end to
/// `on_window`, with the columns (scaled) accumulated since the node
/// before, and whether it is a node (the dwell it lies in; the columns
/// then start again from zero). The columns are the base 24 and then one
/// per effect state of `effects`.
pub(crate) fn walk_nodes(
    ctx: &PassContext,
    comp: &Compensator,
    c_b_n0: &Matrix3<f64>,
    window_s: f64,
    effects: &EffectTerms,
    progress: &mut dyn FnMut(f64),
    mut on_window: impl FnMut(&WindowEnd, &DMatrix<f64>, Option<usize>),
) -> Result<(), CalibError> {
    // Used only to accumulate the parameter columns between nodes.
    let mut sens = ctx.column_accumulator(&effects.scale);
    let mut schedule = NodeSchedule::new(window_s);
    walk(
        ctx,
        comp,
        c_b_n0,
        &mut sens,
        effects,
        progress,
        |sens, w| {
            match schedule.node_at(&ctx.scan.segments, w.t_start, w.t_end) {
                Some(d) => on_window(w, &sens.take_sensitivity(), Some(d)),
                None => on_window(w, &sens.sensitivity(), None),
            }
            Ok(())
        },
    )
}

/// The error model over the stretch between nodes k and k+1:
/// [φ; δv]_{k+1} = A [φ; δv]_k + B p + w, w ~ N(0, Q). With the velocity
/// errors at both nodes known (the navigated velocity, the truth being
/// zero), the residual over the unknowns (…, φ_k, φ_{k+1}) is
/// r = L u + d with d the part the known velocities give.
pub(crate) struct Stretch {
    pub a: Matrix6<f64>,
    pub q: Matrix6<f64>,
    /// Q⁻¹, the residual's weight.
    pub w: DMatrix<f64>,
    pub d: DVector<f64>,
}

impl Stretch {
    /// The stretch of length `t` under error dynamics `f` and white noise
    /// of density `qc`, between velocity errors `v_k` and `v_next`; `None`
    /// when Q is singular.
    pub fn new(
        f: &Matrix6<f64>,
        qc: &Matrix6<f64>,
        t: f64,
        v_k: &Vector3<f64>,
        v_next: &Vector3<f64>,
    ) -> Option<Self> {
        let a = transition(f, t);
        let q = process_noise(f, qc, t);
        let w = q.try_inverse()?;
        let a_xv = a.fixed_view::<6, 3>(0, 3) * v_k;
        let mut d = DVector::<f64>::zeros(6);
        for i in 0..3 {
            d[i] = -a_xv[i];
            d[3 + i] = v_next[i] - a_xv[3 + i];
        }
        Some(Stretch {
            a,
            q,
            w: DMatrix::from_column_slice(6, 6, w.as_slice()),
            d,
        })
    }

    /// The stretch as a unit of `grade` is observed over it: across a
    /// motion (`crosses_motion`: its nodes in different segments) whose
    /// velocity the model cannot follow (`Grade::trusts_motion_velocity`:
    /// below navigation grade, turned by hand), the velocity step is no
    /// observation and the attitude carried through it still is, as
    /// `SystematicFilter::forget_velocity` has it in the filter. The
    /// attitude rows then keep their own weight, the inverse of Q's
    /// attitude block: the velocity rows marginalised out. Trusting the
    /// step in the cross-check flagged 1 of 20 clean simulated consumer
    /// runs, forgetting it 0. `None` when a weight is singular.
    pub fn observed(mut self, grade: Grade, crosses_motion: bool) -> Option<Self> {
        if !crosses_motion || grade.trusts_motion_velocity() {
            return Some(self);
        }
        let w_phi = self.q.fixed_view::<3, 3>(0, 0).into_owned().try_inverse()?;
        self.w.fill(0.0);
        self.w.view_mut((0, 0), (3, 3)).copy_from(&w_phi);
        Some(self)
    }

    /// Writes the attitude columns of L from column `at`: −A's attitude
    /// columns for φ_k, then the identity on the attitude rows for
    /// φ_{k+1}.
    pub fn attitude_columns(&self, l: &mut DMatrix<f64>, at: usize) {
        for i in 0..6 {
            for j in 0..3 {
                l[(i, at + j)] = -self.a[(i, j)];
            }
        }
        for j in 0..3 {
            l[(j, at + 3 + j)] = 1.0;
        }
    }
}

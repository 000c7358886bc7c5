//! The internal problem and its plain types: the adjustment's input, the internal observations (what each
//! is, its DG pose and its node interpolation weights), the assembled problem with its parameter layout,
//! and helpers on them (the DG pose at an epoch, a node's correction). Imports no algorithm module:
//! `crate::build` assembles a problem, the algorithm modules read and adjust it.

use faer::Par;
use nalgebra::{Matrix3, Vector2, Vector3, Vector6};
use plumbline_geo::Trajectory;
use plumbline_geo::dg::CameraMount;
use plumbline_geo::trajectory::PositionInterpolation;

use crate::model::DgPose;
use crate::nodes::{Nodes, WeakLink};
use crate::observations::{MotionError, ObservationError, ObservationRef, ObservationSetV1, TiePointId};
use crate::pattern::Pattern;
use crate::standstill::Standstill;

/// What the adjustment works on.
#[derive(Clone, Copy, Debug)]
pub struct AdjustmentInput<'a> {
    /// The DG trajectory.
    pub trajectory: &'a Trajectory,
    /// The observations.
    pub observations: &'a ObservationSetV1,
    /// The panorama camera's mounting (lever arm and boresight) for tie rays.
    pub mount: &'a CameraMount,
    /// Intervals whose relative constraints are weakened (e.g. flagged DG jumps).
    pub weak_links: &'a [WeakLink],
}

/// The observation-specific part of an internal observation. `Standstill`: zero velocity over a standstill,
/// position (or heading) at its end node = at its start node.
#[derive(Clone, Debug)]
pub(crate) enum Kind {
    /// `offset`: the cadastre object's nuisance offset block (then `sigma` is the camera part only).
    Pole {
        observed: Vector3<f64>,
        cadastre: Vector2<f64>,
        sigma: f64,
        offset: Option<usize>,
    },
    Gnss {
        lever: Vector3<f64>,
        measured: Vector3<f64>,
        sigma: Vector3<f64>,
    },
    /// `sigma`: [across, elevation] of [`crate::TieRay::sigmas`].
    Ray {
        point: usize,
        direction: Vector3<f64>,
        sigma: [f64; 2],
    },
    /// `bias`: the aerial frame set's height-bias block.
    Aerial {
        point: usize,
        measured: Vector3<f64>,
        whitening: Matrix3<f64>,
        bias: Option<usize>,
    },
    Standstill {
        offset: Vector3<f64>,
        sigma: f64,
        heading: bool,
    },
    /// Image-derived motion between `time` and `until` (parts: −weights at the start, +weights at the end):
    /// `dg` the DG's own east, north displacement and heading change, `measured` the images'.
    Motion {
        dg: Vector3<f64>,
        measured: Vector3<f64>,
        sigma: Vector3<f64>,
    },
}

/// What an internal observation is, for reporting.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Item {
    /// An observation of the input set.
    Observation(ObservationRef),
    /// The zero-velocity constraint of a detected standstill (position or heading part).
    Standstill(usize),
    /// `motions[index]` of the input set.
    Motion(usize),
}

/// One observation ready to linearise.
#[derive(Clone, Debug)]
pub(crate) struct Obs {
    pub item: Item,
    pub time: f64,
    /// End of the time span the observation constrains (`time` but for standstills).
    pub until: f64,
    pub dg: DgPose,
    /// Nodes and interpolation weights (empty for aerial coordinates).
    pub parts: Vec<(usize, f64)>,
    pub kind: Kind,
    /// Pole updates: (σ_camera, σ_pole) as given.
    pub pole_sigmas: Option<(f64, f64)>,
}

/// The assembled problem.
#[derive(Clone, Debug)]
pub(crate) struct Problem {
    pub nodes: Nodes,
    pub obs: Vec<Obs>,
    pub points: Vec<TiePointId>,
    pub point_init: Vec<Vector3<f64>>,
    /// Prior σ (the cadastre accuracy) of each cadastre object's 2-D offset.
    pub offset_sigma: Vec<f64>,
    /// The aerial frame sets' height biases.
    pub biases: Vec<BiasBlock>,
    pub relative_sigma: Vec<Vector6<f64>>,
    /// Expected position increment of the correction over each link (`crate::chain::Chain::mean`).
    pub relative_mean: Vec<Vector3<f64>>,
    pub prior_sigma: Vec<Vector6<f64>>,
    pub pattern: Pattern,
    pub mount: CameraMount,
    pub skipped: Vec<ObservationError>,
    /// Relative motions not used (broken, or outside the trajectory).
    pub skipped_motions: Vec<MotionError>,
    /// The detected standstills.
    pub standstills: Vec<Standstill>,
    /// Parallelism for the per-observation work.
    pub par: Par,
}

pub(crate) fn dg_pose(trajectory: &Trajectory, t: f64) -> Option<DgPose> {
    let rec = trajectory.interpolate(t, PositionInterpolation::Linear).ok()?;
    Some(DgPose { p: rec.position.p, r: rec.attitude.to_rotation().matrix() })
}

/// A frame set with a bias parameter: its frames, the prior σ and the number of points.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct BiasBlock {
    pub frames: Vec<String>,
    pub prior_sigma: f64,
    pub points: usize,
}

/// The pose correction of node `k`.
pub(crate) fn node(x: &[f64], k: usize) -> Vector6<f64> {
    Vector6::from_column_slice(&x[6 * k..6 * k + 6])
}

impl Problem {
    /// Link k's departure from its expectation: x_{k+1} − x_k − [mean_k; 0].
    pub fn link_residual(&self, x: &[f64], k: usize) -> Vector6<f64> {
        let mut d = node(x, k + 1) - node(x, k);
        for c in 0..3 {
            d[c] -= self.relative_mean[k][c];
        }
        d
    }

    /// Parameter index of the first coordinate of point `p`.
    pub fn point_offset(&self, p: usize) -> usize {
        self.pattern.offsets[self.nodes.len() + p]
    }

    /// Block index of cadastre object `g`'s offset.
    pub fn offset_block(&self, g: usize) -> usize {
        self.nodes.len() + self.points.len() + g
    }

    /// Parameter index of the first coordinate of cadastre object `g`'s offset.
    pub fn offset_param(&self, g: usize) -> usize {
        self.pattern.offsets[self.offset_block(g)]
    }

    /// Block index of aerial frame set `h`'s height bias.
    pub fn bias_block(&self, h: usize) -> usize {
        self.offset_block(self.offset_sigma.len()) + h
    }

    /// Parameter index of aerial frame set `h`'s height bias.
    pub fn bias_param(&self, h: usize) -> usize {
        self.pattern.offsets[self.bias_block(h)]
    }

    /// Every nuisance parameter (pole offset coordinates, height biases) with its prior σ.
    pub fn nuisance_priors(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        let offsets = self.offset_sigma.iter().enumerate().flat_map(|(g, s)| {
            let first = self.offset_param(g);
            [(first, *s), (first + 1, *s)]
        });
        offsets.chain(self.biases.iter().enumerate().map(|(h, b)| (self.bias_param(h), b.prior_sigma)))
    }
}

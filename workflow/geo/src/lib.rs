//! Geometric core of plumbline: frames, poses, the direct-georeferencing formula, camera models,
//! trajectories and their formats, quality measures and tile planning. Synchronous and I/O-free.
//!
//! ```text
//! frames (Map, Body, Camera; Pose, Rotation) ← attitude (roll/pitch/heading, ω φ κ)
//! trajectory::Trajectory (records with σ, interpolation) ← formats (CSV, SBET + smrmsg, raw GNSS/IMU)
//! dg::CameraMount: camera pose = trajectory pose ∘ lever arm and boresight → camera (equirectangular, pinhole)
//! metrics::compare(estimate, reference) → along/cross/height statistics; metrics::median / quantile
//! tiling::plan → the campaign's tiles; angle::wrap
//! ```

pub mod angle;
pub mod attitude;
pub mod camera;
pub mod dg;
pub mod formats;
pub mod frames;
pub mod metrics;
pub mod tiling;
pub mod trajectory;

pub use attitude::{Attitude, NovatelAttitude, OmegaPhiKappa};
pub use frames::{Body, BodyFromCamera, Camera, Frame, Map, MapFromBody, MapFromCamera, Point3, Pose, Rotation, Vec3};
pub use trajectory::{PoseStd, PositionInterpolation, Trajectory, TrajectoryError, TrajectoryRecord, ValidationLimits};

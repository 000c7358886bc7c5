//! Geometric core of plumbline: frames, poses, the direct-georeferencing formula, camera models,
//! trajectories and their formats, quality measures and tile planning. Synchronous and I/O-free.

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

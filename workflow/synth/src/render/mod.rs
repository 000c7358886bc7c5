//! Rendering by ray casting (rayon across rows): equirectangular panoramas with the vehicle's body masked,
//! side-looking depth images, aerial frame images, and the ground-truth point under any pixel (one function, or range + class images
//! of a whole panorama).

mod block;
mod blur;
mod encode;
mod frame;
pub mod realism;
mod shade;
mod surface;

pub use block::{AtErrors, BlockSpec, perturb_block, perturb_pose, plan_block, strip_rotation};
pub use encode::{RenderError, encode_jpeg, encode_png_gray, encode_png_gray16, encode_png_rgb};
pub use frame::{
    AerialOptics, DepthNoise, Panorama, VehicleBody, ground_truth, render_aerial, render_aerial_with, render_depth,
    render_panorama, render_panorama_with,
};
/// The colour images the renderer returns.
pub use image::RgbImage;
pub use realism::{Radiometry, Realism, RealismLevel, Rig};
pub use shade::{Illumination, Scene};
pub use surface::{MAX_RANGE_M, SurfaceClass, SurfaceImage, render_surfaces, surface_point};

//! Shading: materials of every surface, sun and sky light with cast shadows, and the camera's tone curve
//! (exposure, contrast, gamma) — the illumination differences between the two epochs live here.

use nalgebra::Vector3;

use crate::texture::{Rgb, Texture};
use crate::texture::{pulses, unit};
use crate::world::{Epoch, Hit, PoleClass, Preset, Surface, World};

/// Light and camera response of one epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Illumination {
    /// Sun azimuth, radians clockwise from grid north.
    pub sun_azimuth: f64,
    /// Sun elevation above the horizon, radians.
    pub sun_elevation: f64,
    /// Cast shadows (one shadow ray per pixel).
    pub shadows: bool,
    /// Share of sky light, in [0, 1].
    pub ambient: f32,
    /// Linear gain before the tone curve.
    pub exposure: f32,
    /// Contrast about mid-grey.
    pub contrast: f32,
    /// Display gamma.
    pub gamma: f32,
}

impl Illumination {
    /// The drive: high sun from the south-east, soft contrast.
    pub fn mobile() -> Self {
        Self {
            sun_azimuth: 140f64.to_radians(),
            sun_elevation: 50f64.to_radians(),
            shadows: true,
            ambient: 0.45,
            exposure: 1.5,
            contrast: 1.0,
            gamma: 2.2,
        }
    }
    /// The flight: lower sun from the south-west (long shadows), harder contrast, different exposure.
    pub fn aerial() -> Self {
        Self {
            sun_azimuth: 220f64.to_radians(),
            sun_elevation: 35f64.to_radians(),
            shadows: true,
            ambient: 0.4,
            exposure: 1.25,
            contrast: 1.15,
            gamma: 2.0,
        }
    }
    /// Unit vector toward the sun in the map frame.
    pub fn sun(&self) -> Vector3<f64> {
        let (se, ce) = self.sun_elevation.sin_cos();
        Vector3::new(ce * self.sun_azimuth.sin(), ce * self.sun_azimuth.cos(), se)
    }
}

/// A world seen at one epoch under one illumination.
#[derive(Clone, Copy, Debug)]
pub struct Scene<'w> {
    /// The world.
    pub world: &'w World,
    /// Which epoch (parked cars, paint, repairs).
    pub epoch: Epoch,
    /// Light and tone.
    pub light: Illumination,
}

/// How far rays look, metres (beyond an aerial camera's flying height).
pub const FAR: f64 = 10_000.0;

impl<'w> Scene<'w> {
    /// The mobile-mapping epoch with its default light.
    pub fn mobile(world: &'w World) -> Self {
        Self { world, epoch: Epoch::Mobile, light: Illumination::mobile() }
    }
    /// The aerial epoch with its default light.
    pub fn aerial(world: &'w World) -> Self {
        Self { world, epoch: Epoch::Aerial, light: Illumination::aerial() }
    }

    /// Linear radiance along a ray; `pixel_angle` (radians) sizes the texture footprint.
    pub fn radiance(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, pixel_angle: f64) -> Rgb {
        self.radiance_range(origin, dir, pixel_angle).0
    }

    /// [`Scene::radiance`] and the distance to the surface hit (infinite for the sky).
    pub fn radiance_range(&self, origin: &Vector3<f64>, dir: &Vector3<f64>, pixel_angle: f64) -> (Rgb, f64) {
        let Some(hit) = self.world.trace(origin, dir, FAR, self.epoch) else { return (sky(dir), f64::INFINITY) };
        let cos = hit.normal.dot(dir).abs().max(0.15);
        let footprint = hit.t * pixel_angle / cos;
        let albedo = self.albedo(&hit, footprint);
        let sun = self.light.sun();
        let direct = hit.normal.dot(&sun).max(0.0) as f32;
        let lit = if direct > 0.0 && self.light.shadows {
            let start = hit.point + hit.normal * 1e-3;
            if self.world.occluded(&start, &sun, FAR, self.epoch) { 0.0 } else { direct }
        } else {
            direct
        };
        let a = self.light.ambient;
        let l = a + (1.0 - a) * lit;
        ([albedo[0] * l, albedo[1] * l, albedo[2] * l], hit.t)
    }

    /// The camera's tone curve: exposure, contrast about mid-grey, gamma; to 8 bits.
    pub fn tone(&self, c: Rgb) -> [u8; 3] {
        self.tone_levels(c).map(|v| (v + 0.5) as u8)
    }

    /// [`Scene::tone`] before rounding: levels in 0–255.
    pub fn tone_levels(&self, c: Rgb) -> [f32; 3] {
        let f = |v: f32| {
            let x = ((v * self.light.exposure - 0.5) * self.light.contrast + 0.5).clamp(0.0, 1.0);
            x.powf(1.0 / self.light.gamma) * 255.0
        };
        [f(c[0]), f(c[1]), f(c[2])]
    }

    fn albedo(&self, hit: &Hit, footprint: f64) -> Rgb {
        let w = self.world;
        match hit.surface {
            Surface::Ground => Texture::new(w, self.epoch).albedo(hit.point.x, hit.point.y, footprint),
            Surface::Facade(i) => facade(w, i, hit.uv, footprint),
            Surface::Roof(i) => {
                let v = 0.18 + 0.12 * roof_shade(w, i);
                [v * 1.2, v, v * 0.9]
            }
            Surface::Pole(i) => pole_colour(w.poles[i as usize].class),
            Surface::Crown(_) => [0.1, 0.22, 0.07],
            Surface::Car(i) => w.cars[i as usize].colour,
            Surface::Pedestrian(i) => w.pedestrians[i as usize].colour,
        }
    }
}

/// Colours of pole-like objects: dark green lights, grey posts, anthracite traffic lights, brown trunks.
pub fn pole_colour(class: PoleClass) -> Rgb {
    match class {
        PoleClass::StreetLight => [0.05, 0.22, 0.09],
        PoleClass::SignPost => [0.45, 0.45, 0.47],
        PoleClass::TrafficLight => [0.12, 0.12, 0.13],
        PoleClass::Tree => [0.22, 0.15, 0.09],
    }
}

/// A roof's shade in [0, 1): by the building's number in tiny and district; in the city by its centre (to the
/// centimetre), so every window that holds the building gives it the same roof.
fn roof_shade(w: &World, i: u32) -> f32 {
    if w.config.preset == Preset::City {
        let [x, y] = w.buildings.get(i as usize).map_or([0.0; 2], |b| b.shape.center);
        unit(w.config.seed ^ 61, (x * 100.0).round() as i64, (y * 100.0).round() as i64)
    } else {
        unit(w.config.seed ^ 61, i64::from(i), 0)
    }
}

fn facade(w: &World, i: u32, uv: [f64; 2], fp: f64) -> Rgb {
    let b = &w.buildings[i as usize];
    let [along, up] = uv;
    let win = pulses(along, 3.0, 0.8, 1.4, fp) * pulses(up, b.storey, 0.9, 1.5, fp);
    let glass = [0.1, 0.12, 0.16];
    let k = win;
    [
        b.wall[0] + (glass[0] - b.wall[0]) * k,
        b.wall[1] + (glass[1] - b.wall[1]) * k,
        b.wall[2] + (glass[2] - b.wall[2]) * k,
    ]
}

fn sky(dir: &Vector3<f64>) -> Rgb {
    let e = dir.z.clamp(0.0, 1.0) as f32;
    [0.55 - 0.3 * e, 0.7 - 0.25 * e, 0.95 - 0.1 * e]
}

//! What stands in the world: buildings, pole-like objects (street lights, sign posts, traffic lights, trees)
//! and parked cars, with the geometry the ray caster and the ground truth share.

use nalgebra::Vector3;

use super::polyline::P2;

/// An upright box: a building block or a parked car.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxShape {
    /// Centre of the footprint, map easting/northing.
    pub center: P2,
    /// Unit direction of the box's first axis (along the street).
    pub axis: P2,
    /// Half extents along `axis` and across it, metres.
    pub half: [f64; 2],
    /// Height of the base, metres.
    pub base: f64,
    /// Height above the base, metres.
    pub height: f64,
}

impl BoxShape {
    /// Footprint corners, counter-clockwise.
    pub fn corners(&self) -> [P2; 4] {
        let (a, c) = (self.axis, self.center);
        let n = [-a[1], a[0]];
        let at = |u: f64, v: f64| [c[0] + u * a[0] + v * n[0], c[1] + u * a[1] + v * n[1]];
        let [hu, hv] = self.half;
        [at(-hu, -hv), at(hu, -hv), at(hu, hv), at(-hu, hv)]
    }
    /// Whether a planar point lies inside the footprint (grown by `margin`).
    pub fn contains(&self, p: P2, margin: f64) -> bool {
        let (dx, dy) = (p[0] - self.center[0], p[1] - self.center[1]);
        let u = dx * self.axis[0] + dy * self.axis[1];
        let v = -dx * self.axis[1] + dy * self.axis[0];
        u.abs() <= self.half[0] + margin && v.abs() <= self.half[1] + margin
    }
    /// Radius of the footprint's bounding circle.
    pub fn radius(&self) -> f64 {
        self.half[0].hypot(self.half[1])
    }
}

/// A building block with a facade colour.
#[derive(Clone, Debug, PartialEq)]
pub struct Building {
    /// The block's geometry.
    pub shape: BoxShape,
    /// Wall colour, linear RGB.
    pub wall: [f32; 3],
    /// Storey height, metres (windows repeat with it).
    pub storey: f64,
}

/// The kinds of pole-like objects a cadastre lists.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PoleClass {
    /// Street light, 12–20 cm.
    StreetLight,
    /// Sign post, 6–8 cm.
    SignPost,
    /// Traffic-light pole at a junction, 14–20 cm.
    TrafficLight,
    /// Tree trunk, 20–60 cm, slightly leaning, with a crown.
    Tree,
}

/// A pole-like object: a (possibly leaning) cylinder standing on the ground.
#[derive(Clone, Debug, PartialEq)]
pub struct Pole {
    /// Index in [`super::World::poles`].
    pub id: u32,
    /// Its class.
    pub class: PoleClass,
    /// Centre of the cross-section at ground level, map easting/northing (what a cadastre records).
    pub base: P2,
    /// Diameter, metres.
    pub diameter: f64,
    /// Length along the axis, metres.
    pub height: f64,
    /// Horizontal displacement of the axis per metre of height (east, north); zero for upright poles.
    pub lean: P2,
    /// Radius of a tree's crown (a sphere above the trunk), metres; 0 for poles.
    pub crown: f64,
}

impl Pole {
    /// Unit axis direction (upward).
    pub fn axis(&self) -> Vector3<f64> {
        Vector3::new(self.lean[0], self.lean[1], 1.0).normalize()
    }
    /// Centre of the crown sphere, given the ground height.
    pub fn crown_center(&self, ground: f64) -> Vector3<f64> {
        let top = Vector3::new(self.base[0], self.base[1], ground) + self.axis() * self.height;
        top + Vector3::new(0.0, 0.0, self.crown * 0.7)
    }
    /// Lean angle from the vertical, radians.
    pub fn lean_angle(&self) -> f64 {
        self.lean[0].hypot(self.lean[1]).atan()
    }
}

/// A pedestrian: a person-sized box on a sidewalk or a zebra crossing, there at one epoch only.
#[derive(Clone, Debug, PartialEq)]
pub struct Pedestrian {
    /// The person's box (about 0.5 × 0.35 m, 1.6–1.9 m tall).
    pub shape: BoxShape,
    /// Clothing colour, linear RGB.
    pub colour: [f32; 3],
    /// The epoch the person is there at.
    pub epoch: super::Epoch,
}

/// A parked car, present in one or both epochs.
#[derive(Clone, Debug, PartialEq)]
pub struct Car {
    /// The car's box.
    pub shape: BoxShape,
    /// Body colour, linear RGB.
    pub colour: [f32; 3],
    /// Present at the mobile-mapping epoch.
    pub in_mobile: bool,
    /// Present at the aerial epoch.
    pub in_aerial: bool,
}

//! A drive through the synthetic world: the polyline the vehicle follows and what the street is like along it.
//!
//! This is the interface between the world (which knows streets and buildings) and the motion and GNSS error
//! models (which know nothing of geometry beyond it).

use serde::{Deserialize, Serialize};

/// How enclosed the street is at a point: decides GNSS quality (Cazzaniga et al. 2007 §1.2, Meyer et al. 2023 §3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Canyon {
    /// Distance between the building fronts on both sides, metres.
    pub street_width: f64,
    /// Mean height of the buildings on both sides, metres (0 in the open).
    pub building_height: f64,
}

impl Canyon {
    /// Open sky: no buildings.
    pub const OPEN: Canyon = Canyon { street_width: 100.0, building_height: 0.0 };

    /// Height-to-width ratio: 0 in the open, above 1 in a deep canyon.
    pub fn ratio(&self) -> f64 {
        if self.street_width > 0.0 { self.building_height / self.street_width } else { f64::INFINITY }
    }
}

/// One vertex of a route, in the campaign's projected CRS.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Waypoint {
    /// Easting of the lane centre, metres.
    pub east: f64,
    /// Northing of the lane centre, metres.
    pub north: f64,
    /// Height of the road surface, metres.
    pub ground_height: f64,
    /// The terrain's lean across the lane: its rise per metre to the left of travel (a hillside street; the
    /// lane's own cross-fall is the drive's `camber`). 0 on flat ground.
    #[serde(default)]
    pub bank: f64,
    /// Largest speed allowed here, m/s.
    pub speed_limit: f64,
    /// True at a junction (the vehicle may stop here, e.g. at a traffic light).
    pub junction: bool,
    /// The street's enclosure at this point.
    pub canyon: Canyon,
}

/// The path of one campaign's drive (possibly passing some streets several times).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct Route {
    /// Vertices in driving order; consecutive vertices are joined by straight segments.
    pub waypoints: Vec<Waypoint>,
}

impl Route {
    /// The route with every waypoint's canyon replaced by `canyon` (one GNSS environment everywhere).
    pub fn with_canyon(mut self, canyon: Canyon) -> Self {
        for w in &mut self.waypoints {
            w.canyon = canyon;
        }
        self
    }
}

//! Where a map point lies relative to the street it belongs to: the street lookup the ground texture paints
//! by and the relief recesses the carriageways by.

use super::World;
use super::polyline::{self, Station};
use super::streets::Street;

/// Where a point lies relative to the street it belongs to.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Place<'w> {
    pub street: &'w Street,
    pub station: Station,
    /// Distance to the nearest junction area's edge along the street, from `from` and from `to`, metres.
    pub from_end: f64,
    pub to_end: f64,
    /// Inside a junction area.
    pub in_junction: bool,
}

impl World {
    /// The street a point belongs to: the one whose carriageway is nearest; `None` far from all streets.
    pub(crate) fn place(&self, p: [f64; 2]) -> Option<Place<'_>> {
        let w = self;
        let mut best: Option<(f64, &Street, Station)> = None;
        for &(sid, seg) in w.street_grid.at(p) {
            let st = &w.streets[sid as usize];
            let (station, _) = polyline::station_on_segment(&st.points, &st.cum, seg as usize, p);
            let key = station.t.abs() - st.carriageway() / 2.0;
            if best.as_ref().is_none_or(|b| key < b.0) {
                best = Some((key, st, station));
            }
        }
        let (key, street, station) = best?;
        let (j0, j1) = (&w.junctions[street.from as usize], &w.junctions[street.to as usize]);
        // The junction area is paved where it is near some carriageway (rounded corners), not over the kerbs.
        let in_junction = key < 1.0
            && w.junction_grid
                .at(p)
                .iter()
                .any(|&j| polyline::dist(w.junctions[j as usize].pos, p) < w.junctions[j as usize].radius - 1.0);
        Some(Place {
            street,
            station,
            from_end: station.s - j0.radius,
            to_end: street.length() - station.s - j1.radius,
            in_junction,
        })
    }
}

//! The adjuster's logic, shared by `plumbline run` and the adjuster service: merge the tiles' observations,
//! run the global adjustment, and write the campaign's outputs.

//! Steps 1–4 of paper 000 §3: ortho-projection, MM↔MM transformation, corner matching and triangulation.

//! Steps 5–8 of paper 000 §3: MM patch ↔ aerial images, from the initial transformation to the multi-image triangulation.

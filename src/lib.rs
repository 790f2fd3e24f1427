//! manylights: a renderer and measuring instrument for direct lighting in scenes with many
//! emissive triangles.
//!
//! Data flow: [`scene`] (glTF → plain validated data) → [`accel`] (ray queries) →
//! [`lights`] (one light per emissive triangle) → [`select`] (choose a light with probability
//! p_l) → [`integrator`] (the K×N estimator, per camera sample, over parallel tiles) →
//! [`film`] (f64 Welford mean and variance per pixel) → [`image`] (EXR / PNG, atomic writes).

pub mod accel;
pub mod alloc;
pub mod cli;
pub mod color;
pub mod cpu;
pub mod film;
pub mod gen;
pub mod image;
pub mod integrator;
pub mod lights;
pub mod material;
pub mod measure;
pub mod sampling;
pub mod scene;
pub mod select;

//! Scene writing: the glTF 2.0 writer and the built-in scene generators (`manylights gen`),
//! apart from the scene model and its loader, which never use them.

pub mod generate;
pub mod gltf_write;
mod mesh;
pub mod sky;

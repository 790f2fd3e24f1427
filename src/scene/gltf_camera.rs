//! glTF cameras: the `--camera` choice, perspective and orthographic projections converted to
//! [`Camera`], and errors that list the cameras a file has.

use glam::Mat4;
use gltf::camera::Projection;

use super::Camera;

/// Which of the scene's perspective cameras to use, by position in node order or by name.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum CameraChoice {
    #[default]
    First,
    Index(usize),
    Name(String),
}

impl std::str::FromStr for CameraChoice {
    type Err = std::convert::Infallible;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(s.parse()
            .map(CameraChoice::Index)
            .unwrap_or_else(|_| CameraChoice::Name(s.into())))
    }
}

pub(super) type CameraNode<'a> = (gltf::Node<'a>, gltf::Camera<'a>, Mat4);

/// A camera node as a [`Camera`] (None when its projection is degenerate: zero field of view
/// or magnification, or a transform that collapses its view direction).
fn convert_camera((node, cam, world): &CameraNode) -> Option<Camera> {
    let name = node.name().or(cam.name()).unwrap_or("").to_string();
    match cam.projection() {
        Projection::Perspective(p) => {
            Camera::from_world_matrix(name, world, p.yfov(), p.aspect_ratio())
        }
        Projection::Orthographic(o) => Camera::orthographic(name, world, o.xmag(), o.ymag()),
    }
}

/// "0 'near' (perspective), 1 'top' (orthographic)": the cameras a `--camera` may name.
fn list_cameras(cameras: &[CameraNode]) -> String {
    if cameras.is_empty() {
        return "the scene has no camera".into();
    }
    let list: Vec<String> = cameras
        .iter()
        .enumerate()
        .map(|(i, (node, cam, _))| {
            let name = node
                .name()
                .or(cam.name())
                .map_or(String::new(), |n| format!(" '{n}'"));
            let kind = match cam.projection() {
                Projection::Perspective(_) => "perspective",
                Projection::Orthographic(_) => "orthographic",
            };
            format!("{i}{name} ({kind})")
        })
        .collect();
    format!("the scene's cameras: {}", list.join(", "))
}

pub(super) fn choose_camera(
    cameras: &[CameraNode],
    choice: &CameraChoice,
) -> Result<Option<Camera>, String> {
    let chosen = match choice {
        CameraChoice::First => return Ok(cameras.iter().find_map(convert_camera)),
        CameraChoice::Index(i) => cameras
            .get(*i)
            .ok_or_else(|| format!("--camera {i}: no such camera; {}", list_cameras(cameras)))?,
        CameraChoice::Name(name) => cameras
            .iter()
            .find(|(n, c, _)| n.name() == Some(name) || c.name() == Some(name))
            .ok_or_else(|| {
                format!(
                    "--camera '{name}': no camera node or camera of that name; {}",
                    list_cameras(cameras)
                )
            })?,
    };
    convert_camera(chosen).map(Some).ok_or_else(|| {
        "the chosen camera is degenerate (zero field of view or magnification, or a transform \
         without a view direction)"
            .into()
    })
}

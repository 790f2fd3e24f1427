//! Small scene builders shared by tests: a quad as two triangles, a closed box.

use glam::Vec3;
use manylights::scene::Triangle;

/// Two triangles of the quad a, b, c, d (counter-clockwise seen from the front).
pub fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3, m: u32) -> [Triangle; 2] {
    [Triangle::flat([a, b, c], m), Triangle::flat([a, c, d], m)]
}

/// The six faces of the box lo..hi, fronts facing inward.
pub fn closed_box(lo: Vec3, hi: Vec3, m: u32) -> Vec<Triangle> {
    let p = |x: bool, y: bool, z: bool| {
        Vec3::new(
            if x { hi.x } else { lo.x },
            if y { hi.y } else { lo.y },
            if z { hi.z } else { lo.z },
        )
    };
    let (f, t) = (false, true);
    [
        quad(p(f, f, f), p(t, f, f), p(t, f, t), p(f, f, t), m), // y = lo, +Y
        quad(p(f, t, f), p(f, t, t), p(t, t, t), p(t, t, f), m), // y = hi, −Y
        quad(p(f, f, f), p(f, f, t), p(f, t, t), p(f, t, f), m), // x = lo, +X
        quad(p(t, f, f), p(t, t, f), p(t, t, t), p(t, f, t), m), // x = hi, −X
        quad(p(f, f, f), p(f, t, f), p(t, t, f), p(t, f, f), m), // z = lo, +Z
        quad(p(f, f, t), p(t, f, t), p(t, t, t), p(f, t, t), m), // z = hi, −Z
    ]
    .concat()
}

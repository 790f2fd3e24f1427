//! Each emitting triangle's selection power against a brute-force stratified average of the
//! bilinear texture over its uv footprint.

use super::*;

#[test]
pub(crate) fn triangle_power_matches_a_brute_force_average_over_its_texels() {
    let scene = scene(Uvs::Continuous(FINE));
    let lights = Lights::from_scene(&scene);
    let expected = emitter_triangles(Uvs::Continuous(FINE));
    assert_eq!(lights.triangle_count(), expected.len());
    let brightest = emissive_codes()
        .iter()
        .map(|c| luminance64(EMISSIVE_FACTOR * DVec3::from_array(c.map(srgb_decode))))
        .fold(0.0, f64::max);
    let (mut zero, mut lit) = (0, 0);
    for light in lights.triangles() {
        let t = light.triangle as usize;
        let (positions, uvs) = expected[t];
        assert_eq!(scene.uvs[t], uvs, "triangle {t}'s uvs as written");
        let area = 0.5
            * (positions[1] - positions[0])
                .cross(positions[2] - positions[0])
                .length();
        // 224² strata of the barycentric square, two jittered points in each (fixed sequence):
        // mean and the stratified estimator's variance Σ (f₁ − f₂)² / (4 N²).
        let strata = 224;
        let (mut sum, mut diff2) = (0.0, 0.0);
        let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ t as u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for a in 0..strata {
            for b in 0..strata {
                let mut pair = [0.0; 2];
                for value in &mut pair {
                    let u1 = (a as f64 + next()) / strata as f64;
                    let u2 = (b as f64 + next()) / strata as f64;
                    let (b1, b2) = (u1.sqrt() * (1.0 - u2), u1.sqrt() * u2);
                    let uv = uvs[0].as_dvec2()
                        + b1 * (uvs[1] - uvs[0]).as_dvec2()
                        + b2 * (uvs[2] - uvs[0]).as_dvec2();
                    *value = luminance64(emission(uv.as_vec2(), (REPEAT, MIRROR)));
                }
                sum += pair[0] + pair[1];
                diff2 += (pair[0] - pair[1]).powi(2);
            }
        }
        let n = (strata * strata) as f64;
        let mean = sum / (2.0 * n);
        let sigma = (diff2 / (4.0 * n * n)).sqrt();
        let brute = std::f64::consts::PI * area * mean;
        let power = light.power();
        // 5σ of the brute force, the power floor (1e-6 of the brightest reachable texel) and
        // f32 rounding of the stored radiance.
        let tolerance =
            std::f64::consts::PI * area * (5.0 * sigma + 1e-6 * brightest) + 1e-5 * brute;
        assert!(
            (power - brute).abs() <= tolerance,
            "triangle {t}: power {power} but the brute-force average gives {brute} (±{tolerance})"
        );
        if brute > 0.0 {
            assert!(power > 0.0, "triangle {t} emits but has zero power");
            lit += 1;
        } else {
            zero += 1;
        }
    }
    // The premise: a mostly dark texture, so that power from the factor alone would mislead.
    assert!(
        zero > 0 && lit > 0 && lit < expected.len() / 2,
        "{lit} lit, {zero} dark"
    );
}

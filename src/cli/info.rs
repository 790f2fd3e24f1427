//! `manylights info SCENE`: what a scene holds, before rendering it.

use std::path::PathBuf;

use clap::Args;

use crate::color::luminance;
use crate::lights::power_stats::PowerStats;
use crate::lights::{punctual, Light, Lights};
use crate::scene::{
    load_gltf_allowing, CameraChoice, LoadPolicy, PunctualKind, PunctualUnits, Scene,
};

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The scene, .gltf or .glb.
    pub scene: PathBuf,
    /// Camera node index (in scene order) or name.
    #[arg(long)]
    pub camera: Option<CameraChoice>,
    /// Units of KHR_lights_punctual intensities (as for render).
    #[arg(long, value_enum, default_value_t = PunctualUnits::Photometric)]
    pub punctual_units: PunctualUnits,
    /// Also read the scene's external files (buffers, images) from inside this folder
    /// (repeatable).
    #[arg(long, value_name = "DIR", value_parser = super::options::existing_folder)]
    pub allow_external_files: Vec<PathBuf>,
}

pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    let camera = args.camera.clone().unwrap_or_default();
    let policy = LoadPolicy {
        allowed: args.allow_external_files.clone(),
        memory: None,
    };
    let scene =
        load_gltf_allowing(&args.scene, &camera, &policy)?.with_punctual_units(args.punctual_units);
    let lights = Lights::from_scene(&scene);
    let two_sided = lights.triangles().filter(|l| l.two_sided).count();
    let (lo, hi) = scene.bounds();
    println!("scene              {}", args.scene.display());
    println!("triangles          {}", scene.triangles.len());
    println!(
        "emissive triangles {} ({} two-sided)",
        lights.triangle_count(),
        two_sided
    );
    let triangle_power = lights.triangles().fold(0.0, |sum, t| sum + t.power());
    println!("triangle power     {triangle_power:.6e} W (Φ = π·A·luminance, ×2 two-sided)");
    print_punctual(&scene);
    println!(
        "total power        {:.6e} W (every light)",
        lights.total_power()
    );
    println!("materials          {}", scene.materials.len());
    if !scene.textures.is_empty() {
        const LISTED: usize = 8;
        let mut sizes: Vec<String> = (scene.textures.iter().take(LISTED))
            .map(|t| format!("{}×{}", t.width, t.height))
            .collect();
        if scene.textures.len() > LISTED {
            sizes.push("…".into());
        }
        println!(
            "textures           {} ({})",
            scene.textures.len(),
            sizes.join(", ")
        );
        println!(
            "textured emitters  {} (power from each one's emissive texture mean over its own uv footprint)",
            lights.triangles().filter(|l| l.textured).count()
        );
    }
    println!(
        "bounds             [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    match &scene.camera {
        Some(c) => println!("camera             {}", c.describe()),
        None => println!(
            "camera             none (render frames the bounds: {})",
            crate::scene::Camera::FRAMING_DIRECTION_TEXT
        ),
    }
    if let Some(p) = PowerStats::of(&lights) {
        println!(
            "power per light    min non-zero {:.3e}  median {:.3e}  max {:.3e} W ({} with zero power)",
            p.min_positive, p.median, p.max, p.zero
        );
        println!(
            "top 1% of lights   hold {:.1}% of the power",
            100.0 * p.top_percent_share
        );
        println!(
            "emissive sides     {} one-sided, {} two-sided",
            p.one_sided, p.two_sided
        );
        print!("power histogram\n{}", p.histogram(40));
    }
    let s = &scene.stats;
    println!(
        "skipped            {} degenerate triangles, {} primitives without area (points, lines)",
        s.degenerate_triangles, s.skipped_primitives
    );
    for name in &s.skipped_primitive_names {
        println!("  without area     {name}");
    }
    Ok(())
}

/// One line per KHR_lights_punctual light: kind, colour × intensity in the file's units, and the
/// power the light selectors give it (W).
fn print_punctual(scene: &Scene) {
    if scene.punctual.is_empty() {
        return;
    }
    let units = scene.punctual_units;
    println!(
        "punctual lights    {} ({} units{})",
        scene.punctual.len(),
        match units {
            PunctualUnits::Photometric => "photometric",
            PunctualUnits::Radiometric => "radiometric",
        },
        match units {
            PunctualUnits::Photometric => ", ÷ 683 lm/W to W/sr and W/m²",
            PunctualUnits::Radiometric => "",
        }
    );
    let (lo, hi) = scene.bounds();
    let radius = 0.5 * (hi - lo).length();
    for (i, l) in scene.punctual.iter().enumerate() {
        let (kind, formula) = match l.kind {
            PunctualKind::Point => ("point", "4π·I"),
            PunctualKind::Spot { .. } => ("spot", "cone solid angle·I"),
            PunctualKind::Directional => ("directional", "π·R²·E over the scene's bounding sphere"),
        };
        let power = match punctual::from_punctual(l, radius, units) {
            Light::Point(p) => p.power(),
            Light::Directional(d) => d.power(),
            _ => 0.0,
        };
        let [r, g, b] = l.intensity.to_array();
        println!(
            "  {i:<3} {kind:<11} colour × intensity [{r:.4e}, {g:.4e}, {b:.4e}] {} (luminance {:.4e}), power {power:.4e} W ({formula})",
            units.unit(l.kind),
            luminance(l.intensity),
        );
    }
}

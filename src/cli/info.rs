//! `manylights info SCENE`: what a scene holds, before rendering it.

use std::path::PathBuf;

use clap::Args;

use crate::lights::power_stats::PowerStats;
use crate::lights::Lights;
use crate::scene::{load_gltf_allowing, CameraChoice};

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// The scene, .gltf or .glb.
    pub scene: PathBuf,
    /// Camera node index (in scene order) or name.
    #[arg(long)]
    pub camera: Option<CameraChoice>,
    /// Also read the scene's external files (buffers, images) from inside this folder
    /// (repeatable).
    #[arg(long, value_name = "DIR", value_parser = super::options::existing_folder)]
    pub allow_external_files: Vec<PathBuf>,
}

pub fn run(args: &InfoArgs) -> anyhow::Result<()> {
    let camera = args.camera.clone().unwrap_or_default();
    let scene = load_gltf_allowing(&args.scene, &camera, &args.allow_external_files)?;
    let lights = Lights::from_scene(&scene);
    let two_sided = lights.triangles().filter(|l| l.two_sided).count();
    let (lo, hi) = scene.bounds();
    println!("scene              {}", args.scene.display());
    println!("triangles          {}", scene.triangles.len());
    println!(
        "emissive triangles {} ({} two-sided)",
        lights.len(),
        two_sided
    );
    println!(
        "total power        {:.6e} W (Φ = π·A·luminance, ×2 two-sided)",
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
        Some(c) => println!(
            "camera             '{}' at [{:.3}, {:.3}, {:.3}] looking [{:.3}, {:.3}, {:.3}], yfov {:.2}°, aspect {}",
            c.name,
            c.position.x,
            c.position.y,
            c.position.z,
            c.forward.x,
            c.forward.y,
            c.forward.z,
            c.yfov.to_degrees(),
            c.aspect_ratio.map_or("from --width/--height".into(), |a| format!("{a:.4}"))
        ),
        None => println!("camera             none (render frames the bounds from +Z)"),
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
        "skipped            {} degenerate triangles, {} non-triangle primitives",
        s.degenerate_triangles, s.skipped_primitives
    );
    Ok(())
}

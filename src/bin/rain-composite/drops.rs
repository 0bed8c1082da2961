//! `rain-composite drops …`: the streak-matte database.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use rain_composite::drops::DatabaseSpec;
use rain_composite::drops::database;

#[derive(Subcommand, Debug)]
pub enum DropsCommand {
    /// Ray-trace oscillating drops into a streak-matte database: 16-bit PNGs + index.json
    /// (the defaults make the database shipped in drops/).
    Generate(GenerateArgs),
}

#[derive(Args, Debug)]
pub struct GenerateArgs {
    /// Output folder (created if missing; files of the same name are replaced).
    #[arg(short, long)]
    output: PathBuf,
    /// Drop diameters, mm [default: 1,2,4].
    #[arg(long, value_delimiter = ',', value_name = "MM")]
    sizes: Option<Vec<f64>>,
    /// Exposure times, seconds or 1/N [default: 1/60].
    #[arg(long, value_delimiter = ',', value_name = "S")]
    exposures: Option<Vec<String>>,
    /// Camera elevations, degrees in [0, 85] [default: 0,30,60].
    #[arg(long, value_delimiter = ',', value_name = "DEG")]
    views: Option<Vec<f64>>,
    /// Oscillation phases per streak, 1 to 64 [default: 4].
    #[arg(long)]
    phases: Option<usize>,
    /// Pixels across the drop's diameter [default: 8].
    #[arg(long)]
    pixels_per_diameter: Option<f64>,
    /// Samples per pixel side and time steps per pixel of travel, 1 to 16 [default: 2].
    #[arg(long)]
    samples: Option<usize>,
}

/// "1/60" or "0.0167".
fn parse_exposure(text: &str) -> anyhow::Result<f64> {
    let value = match text.split_once('/') {
        Some((n, d)) => n
            .trim()
            .parse::<f64>()
            .ok()
            .zip(d.trim().parse::<f64>().ok())
            .map(|(n, d)| n / d),
        None => text.trim().parse().ok(),
    };
    value
        .filter(|v| v.is_finite() && *v > 0.0)
        .with_context(|| {
            format!("invalid --exposures '{text}': expected seconds, e.g. 0.02 or 1/60")
        })
}

pub fn run(command: &DropsCommand) -> anyhow::Result<()> {
    let DropsCommand::Generate(args) = command;
    let defaults = DatabaseSpec::default();
    let spec = DatabaseSpec {
        sizes_mm: args.sizes.clone().unwrap_or(defaults.sizes_mm),
        exposures_s: match &args.exposures {
            Some(list) => list
                .iter()
                .map(|t| parse_exposure(t))
                .collect::<anyhow::Result<_>>()?,
            None => defaults.exposures_s,
        },
        view_elevations_deg: args.views.clone().unwrap_or(defaults.view_elevations_deg),
        phases: args.phases.unwrap_or(defaults.phases),
        pixels_per_diameter: args
            .pixels_per_diameter
            .unwrap_or(defaults.pixels_per_diameter),
        samples: args.samples.unwrap_or(defaults.samples),
        ..defaults
    };
    if !(spec.pixels_per_diameter.is_finite() && (1.0..=64.0).contains(&spec.pixels_per_diameter)) {
        bail!(
            "invalid --pixels-per-diameter {}: expected 1 to 64",
            spec.pixels_per_diameter
        );
    }
    let terminal = std::io::stderr().is_terminal();
    let index = database::generate(&spec, &args.output, &crate::INTERRUPTED, |done, total| {
        if terminal {
            eprint!("\r{done}/{total} streaks");
        }
    })?;
    if terminal {
        eprintln!();
    }
    log::info!(
        "{} mattes written to {}",
        index.mattes.len(),
        args.output.display()
    );
    Ok(())
}

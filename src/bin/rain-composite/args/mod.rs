//! The command line's shape (clap) and its translation into the library's settings. Defaults
//! of values that live in the library are read from it (`RenderConfig::default`,
//! `EncodeOptions::default`), never repeated here.
//!
//! - `render`: the render's own flags (input, output, frames, progress, GPU).
//! - `commands`: the flags of `preview`, `config` and `probe`.
//! - `look`: the rain, camera, light and ground flags, and the configuration they make.
//! - `encode`: the encoder flags and the options they make.
//! - `help`: the definition the help shows, with the library's defaults.

use clap::{Args, Parser, Subcommand};

use crate::bench::BenchArgs;
use crate::drops::DropsCommand;
use crate::inspect::InspectCommand;

mod commands;
mod encode;
mod help;
mod look;
mod render;

pub use commands::{Bits, ConfigArgs, PreviewArgs, ProbeArgs};
pub use encode::{EncodeArgs, encode_options};
pub use help::{command, parse};
pub use look::{LookArgs, render_config};
pub use render::{
    CheckpointArgs, GpuArgs, ProgressMode, RenderArgs, adapter, frame_range, parse_time_s,
};

/// Adds physically based rain to video.
#[derive(Parser, Debug)]
#[command(
    name = "rain-composite",
    version,
    args_conflicts_with_subcommands = true,
    allow_negative_numbers = true
)]
#[command(
    after_help = "Examples:\n  rain-composite in.mp4 -o out.mp4 --rain heavy --wind 3,0\n  rain-composite preview in.mp4 --at 2.5s -o frame.png\n  ffmpeg -i in.mp4 -f yuv4mpegpipe - | rain-composite - -o - | ffplay -"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    #[command(flatten)]
    pub render: RenderArgs,
    #[command(flatten)]
    pub log: LogArgs,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render one frame exactly as the full render would, to a PNG.
    #[command(allow_negative_numbers = true)]
    Preview(PreviewArgs),
    /// Describe the streams of a file: colour tags, rotation, frame rate, what would be copied.
    Probe(ProbeArgs),
    /// Print the models behind the rain as JSON (drop sampling, ...).
    #[command(subcommand)]
    Inspect(InspectCommand),
    /// Streak mattes: generate the database of ray-traced oscillating drops.
    #[command(subcommand)]
    Drops(DropsCommand),
    /// Time a full render against a plain ffmpeg transcode of the same clip (needs the ffmpeg CLI).
    #[command(allow_negative_numbers = true)]
    Bench(BenchArgs),
    /// Print the effective configuration as JSON (`--print`), or list the presets (`--list`).
    Config(ConfigArgs),
    /// Print a shell completion script (bash: `source <(rain-composite completions bash)`).
    Completions {
        /// The shell.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff), generated from these options: `rain-composite man > rain-composite.1`.
    Man,
    /// List the GPU adapters, best first.
    Adapters {
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Args, Debug)]
pub struct LogArgs {
    /// Print only errors.
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// Print more (repeat for debug output).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
}

/// The command line `args` parsed as [`parse`] parses the process's.
#[cfg(test)]
pub fn parsed(args: &[&str]) -> Cli {
    use clap::FromArgMatches;
    let m = command()
        .try_get_matches_from(args)
        .unwrap_or_else(|e| panic!("{args:?}: {e}"));
    Cli::from_arg_matches(&m).expect("matches")
}

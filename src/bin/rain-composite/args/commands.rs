//! The flags of `preview`, `config` and `probe`.

use clap::{Args, ValueEnum};

use super::look::LookArgs;
use super::render::{CheckpointArgs, GpuArgs};

#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// Input video.
    pub input: String,
    /// Time of the frame: seconds, or with a unit (2.5s, 1500ms, 00:01:02.5).
    #[arg(long, conflicts_with = "frame", required_unless_present = "frame")]
    pub at: Option<String>,
    /// Zero-based frame index.
    #[arg(long)]
    pub frame: Option<u64>,
    /// Output PNG, or - for stdout.
    #[arg(short, long)]
    pub output: String,
    /// Overwrite the output if it exists.
    #[arg(short = 'y', long)]
    pub overwrite: bool,
    /// Bits per PNG channel.
    #[arg(long, value_enum, default_value_t = Bits::Eight)]
    pub bits: Bits,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    #[command(flatten)]
    pub checkpoints: CheckpointArgs,
}

#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ConfigArgs {
    /// Print the configuration the same --config, --set and flags give a render, as JSON that --config FILE reads back.
    #[arg(long, conflicts_with = "list", required_unless_present = "list")]
    pub print: bool,
    /// List the presets, one line each.
    #[arg(long)]
    pub list: bool,
    #[command(flatten)]
    pub look: LookArgs,
}

#[derive(Args, Debug)]
pub struct ProbeArgs {
    /// Input video.
    pub input: String,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Container the output would be written to (decides what can be copied).
    #[arg(long, value_name = "EXT")]
    pub for_output: Option<String>,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum Bits {
    /// 8 bits per channel.
    #[value(name = "8")]
    Eight,
    /// 16 bits per channel.
    #[value(name = "16")]
    Sixteen,
}

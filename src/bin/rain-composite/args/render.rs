//! The render's own flags: what it reads and writes, which frames, the progress report and
//! the GPU.

use clap::{Args, ValueEnum};
use rain_composite::gpu::{AdapterRequest, Backend};
use rain_composite::pipeline::FrameRange;

use super::encode::EncodeArgs;
use super::look::LookArgs;

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Input video, or - for a stream on stdin (y4m, nut, matroska, mpegts).
    pub input: Option<String>,
    /// Output video (container from the extension), or - for stdout.
    #[arg(short, long)]
    pub output: Option<String>,
    /// Overwrite the output if it exists.
    #[arg(short = 'y', long)]
    pub overwrite: bool,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub encode: EncodeArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// Progress report on stderr.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    pub progress: ProgressMode,
    /// Render only these frames (zero-based): A..B is A up to but not including B, A..=B includes B, A.. runs to the end. Chunks joined with `ffmpeg -f concat` equal the whole render.
    #[arg(long, value_name = "A..B", conflicts_with_all = ["from", "to"])]
    pub frames: Option<String>,
    /// Render only the frames shown at or after this time (seconds, 2.5s, 1500ms, 00:01:02.5).
    #[arg(long, value_name = "TIME")]
    pub from: Option<String>,
    /// Render only the frames shown before this time.
    #[arg(long, value_name = "TIME")]
    pub to: Option<String>,
    /// With --puddles: keep the water in a file after every N-th frame, so chunks start from the latest one at or before their first frame instead of simulating the water from the clip's start; 0 = keep none (kept files are still read).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub checkpoint_every: u64,
    #[command(flatten)]
    pub checkpoints: CheckpointArgs,
}

/// Where the puddles' water is kept between chunks.
#[derive(Args, Debug, Clone)]
pub struct CheckpointArgs {
    /// Folder of the puddles' water checkpoints, beside the output (a render) or the input (a preview) [default: STEM.water].
    #[arg(long, value_name = "DIR")]
    pub checkpoints: Option<std::path::PathBuf>,
}

impl CheckpointArgs {
    /// The folder: as given, or `<stem of input>.water` in `beside`'s folder.
    pub fn dir(&self, input: &str, beside: &str) -> std::path::PathBuf {
        use std::path::Path;
        if let Some(d) = &self.checkpoints {
            return d.clone();
        }
        let stem = Path::new(input)
            .file_stem()
            .map_or_else(|| "stdin".into(), |s| s.to_string_lossy().into_owned());
        let folder = match Path::new(beside).parent() {
            Some(p) if beside != "-" && !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => std::path::PathBuf::from("."),
        };
        folder.join(format!("{stem}.water"))
    }
}

#[derive(Args, Debug, Clone)]
pub struct GpuArgs {
    /// Use the adapter whose name contains NAME (see `rain-composite adapters`).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Use a CPU (software) adapter only.
    #[arg(long)]
    pub cpu: bool,
    /// Where the colour passes (planes → linear with the haze, linear → code values) run: auto (the CPU on a CPU adapter such as lavapipe or on one whose vertex shaders cannot read storage buffers, else the GPU), gpu or cpu. On cpu everything else a frame needs runs on the CPU as well (the wet ground, the puddles, the drops and the splashes, simulated and drawn): the adapter renders nothing.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
}

/// `--backend`'s values (the library's [`Backend`]).
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum BackendArg {
    /// The CPU on a CPU adapter or one the GPU's streaks cannot run on, else the GPU.
    Auto,
    /// The GPU's shaders.
    Gpu,
    /// The CPU back end.
    Cpu,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq)]
pub enum ProgressMode {
    /// A bar when stderr is a terminal, nothing otherwise.
    Auto,
    /// One JSON object per line on stderr.
    Json,
    /// Nothing.
    None,
}

/// A time of the stream: seconds, `2.5s`, `1500ms` or `00:01:02.5`.
pub fn parse_time_s(s: &str) -> anyhow::Result<f64> {
    let bad = || {
        anyhow::anyhow!("invalid time '{s}': expected seconds (2.5, 2.5s, 1500ms or 00:01:02.5)")
    };
    let t = if let Some(ms) = s.strip_suffix("ms") {
        ms.trim().parse::<f64>().map_err(|_| bad())? / 1000.0
    } else if s.contains(':') {
        // [[HH:]MM:]SS: at most three fields, minutes and seconds below 60 after the first.
        let parts: Vec<&str> = s.split(':').collect();
        if parts.len() > 3 {
            return Err(bad());
        }
        let values = parts
            .iter()
            .map(|p| p.trim().parse::<f64>())
            .collect::<Result<Vec<f64>, _>>()
            .map_err(|_| bad())?;
        if values[1..].iter().any(|v| !(0.0..60.0).contains(v)) {
            return Err(bad());
        }
        values.iter().fold(0.0, |acc, v| acc * 60.0 + v)
    } else {
        s.strip_suffix('s')
            .unwrap_or(s)
            .trim()
            .parse::<f64>()
            .map_err(|_| bad())?
    };
    if !t.is_finite() || t < 0.0 {
        return Err(bad());
    }
    Ok(t)
}

/// The frames `--frames` or `--from`/`--to` ask for.
pub fn frame_range(r: &RenderArgs) -> anyhow::Result<FrameRange> {
    if let Some(text) = &r.frames {
        let bad = || {
            anyhow::anyhow!(
                "invalid --frames '{text}': expected A..B (B excluded), A..=B (B included) or A.."
            )
        };
        let (a, b) = text.split_once("..").ok_or_else(bad)?;
        let start: u64 = a.trim().parse().map_err(|_| bad())?;
        let end = match b.strip_prefix('=') {
            Some(b) => Some(
                b.trim()
                    .parse::<u64>()
                    .ok()
                    .and_then(|b| b.checked_add(1))
                    .ok_or_else(bad)?,
            ),
            None if b.trim().is_empty() => None,
            None => Some(b.trim().parse().map_err(|_| bad())?),
        };
        return Ok(FrameRange::Indices { start, end });
    }
    if r.from.is_none() && r.to.is_none() {
        return Ok(FrameRange::All);
    }
    Ok(FrameRange::Times {
        from_s: r
            .from
            .as_deref()
            .map(parse_time_s)
            .transpose()?
            .unwrap_or(0.0),
        to_s: r.to.as_deref().map(parse_time_s).transpose()?,
    })
}

/// Which GPU adapter the flags ask for.
pub fn adapter(g: &GpuArgs) -> AdapterRequest {
    AdapterRequest {
        name: g.adapter.clone(),
        cpu_only: g.cpu,
        backend: match g.backend {
            BackendArg::Auto => Backend::Auto,
            BackendArg::Gpu => Backend::Gpu,
            BackendArg::Cpu => Backend::Cpu,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::args::parsed;

    /// `--frames` reads half-open, inclusive and open-ended ranges; `--from`/`--to` times.
    #[test]
    fn frame_ranges_parse() {
        let range = |args: &[&str]| {
            let mut all = vec!["rain-composite", "in.mp4"];
            all.extend_from_slice(args);
            frame_range(&parsed(&all).render)
        };
        let idx = |start, end| FrameRange::Indices { start, end };
        assert_eq!(range(&["--frames", "3..8"]).ok(), Some(idx(3, Some(8))));
        assert_eq!(range(&["--frames", "3..=8"]).ok(), Some(idx(3, Some(9))));
        assert_eq!(range(&["--frames", "3.."]).ok(), Some(idx(3, None)));
        assert_eq!(range(&[]).ok(), Some(FrameRange::All));
        assert_eq!(
            range(&["--from", "1.5s", "--to", "00:00:04"]).ok(),
            Some(FrameRange::Times {
                from_s: 1.5,
                to_s: Some(4.0)
            })
        );
        for bad in ["3", "a..b", "..4", "3..=x"] {
            let e = range(&["--frames", bad]).expect_err(bad).to_string();
            assert!(e.contains("--frames") && e.contains(bad), "{e}");
        }
    }
}

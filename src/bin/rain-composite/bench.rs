//! `rain-composite bench`: speed of a full render against a plain `ffmpeg` transcode of the
//! same clip with the same codec settings, measured side by side in one run (medians). The
//! colour passes' columns are GPU time on the GPU back end and CPU time on the CPU back end
//! (the back end column says which).

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use rain_composite::pipeline::{self, Job, StageTimes};

use crate::args::{EncodeArgs, GpuArgs, LookArgs, adapter, encode_options, render_config};

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Input video (scaled to each height).
    pub input: String,
    /// Picture heights to test.
    #[arg(long, value_delimiter = ',', default_value = "720,1080")]
    pub heights: Vec<u32>,
    /// Runs per measurement (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
    pub runs: u32,
    #[command(flatten)]
    pub look: LookArgs,
    #[command(flatten)]
    pub encode: EncodeArgs,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// `rain-composite bench`: checks the input, then measures.
pub fn run_command(b: &BenchArgs) -> anyhow::Result<()> {
    check_input(&b.input)?;
    let job = Job {
        input: b.input.clone(),
        output: String::new(),
        render: render_config(&b.look)?,
        encode: encode_options(&b.encode, true)?,
        adapter: adapter(&b.gpu),
        frames: Default::default(),
        checkpoints: None,
    };
    run(&job, &b.input, &b.heights, b.runs as usize)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn ffmpeg(args: &[&str]) -> anyhow::Result<()> {
    let out = Command::new("ffmpeg")
        .args(["-hide_banner", "-loglevel", "error", "-y"])
        .args(args)
        .output()
        .context("running ffmpeg (the benchmark needs the ffmpeg CLI)")?;
    if !out.status.success() {
        bail!(
            "ffmpeg {args:?}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(())
}

/// Runs the benchmark on `input` scaled to each height in `heights`; prints a Markdown table.
fn run(template: &Job, input: &str, heights: &[u32], runs: usize) -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("rain-composite-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let result = (|| -> anyhow::Result<()> {
        println!(
            "| size | back end | frames | drops | rain-composite wall (s) | ffmpeg transcode wall (s) | ratio | decode | upload+record | yuv→rgb | GPU rain | rgb→yuv | wait+readback | encode | ms/frame total |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
        for &h in heights {
            let clip = dir.join(format!("in-{h}.mp4"));
            let scale = format!("scale=-2:{h}");
            let clip_s = clip.to_str().context("temp path")?;
            ffmpeg(&[
                "-i", input, "-vf", &scale, "-c:v", "libx264", "-crf", "16", "-pix_fmt", "yuv420p",
                clip_s,
            ])?;
            let out = dir.join("out.mp4");
            let out_s = out.to_str().context("temp path")?.to_string();
            let (mut ours, mut theirs) = (Vec::new(), Vec::new());
            let mut stages: Vec<StageTimes> = Vec::new();
            let mut frames = 0;
            let mut drops = 0;
            let mut adapter = String::new();
            let mut backend = rain_composite::gpu::Backend::Auto;
            for _ in 0..runs {
                // Interleave the two so both see the same machine load.
                let mut job = Job {
                    input: clip_s.to_string(),
                    output: out_s.clone(),
                    ..template.clone()
                };
                job.encode.overwrite = true;
                let s = pipeline::render(&job, &crate::INTERRUPTED, &mut |_| {})?;
                ours.push(s.elapsed_s);
                stages.push(s.stages);
                frames = s.frames;
                drops = s.drops;
                adapter = s.adapter;
                backend = s.backend;
                let crf = job.encode.crf.to_string();
                let mut args = vec!["-i", clip_s, "-c:v", "libx264", "-crf", &crf];
                args.extend(["-preset", &job.encode.preset]);
                // The same encoder options as the render's, so the two write the same stream.
                if !job.encode.encoder_params.is_empty() {
                    args.extend(["-x264-params", &job.encode.encoder_params]);
                }
                args.extend(["-c:a", "copy", &out_s]);
                let t = Instant::now();
                ffmpeg(&args)?;
                theirs.push(t.elapsed().as_secs_f64());
            }
            let per_frame = |f: fn(&StageTimes) -> f64| {
                1000.0 * median(stages.iter().map(f).collect()) / frames.max(1) as f64
            };
            let (a, b) = (median(ours), median(theirs));
            println!(
                "| {h}p | {} | {frames} | {drops} | {a:.2} | {b:.2} | {:.2} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
                backend.name(),
                a / b,
                per_frame(|s| s.decode_s),
                per_frame(|s| s.submit_s),
                per_frame(|s| s.gpu.yuv_to_rgb_s),
                per_frame(|s| s.gpu.rain_simulate_s + s.gpu.rain_splashes_s + s.gpu.rain_streaks_s),
                per_frame(|s| s.gpu.rgb_to_yuv_s),
                per_frame(|s| s.readback_s),
                per_frame(|s| s.encode_s),
                1000.0 * a / frames.max(1) as f64,
            );
            eprintln!(
                "{h}p on {adapter}; of GPU rain, splashes {:.1} ms/frame, rain_simulate {:.1}, \
                 rain_streaks {:.1}; streaks drawn {:.0} per frame of {drops} drops simulated, \
                 splash streaks drawn {:.0} per frame; tiles decoded and encoded {:.0} of {:.0} \
                 per frame (the rest passed through)",
                per_frame(|s| s.gpu.rain_splashes_s),
                per_frame(|s| s.gpu.rain_simulate_s),
                per_frame(|s| s.gpu.rain_streaks_s),
                per_frame(|s| s.gpu.streaks_drawn as f64) / 1000.0,
                per_frame(|s| s.gpu.splashes_drawn as f64) / 1000.0,
                per_frame(|s| s.gpu.tiles_converted as f64) / 1000.0,
                per_frame(|s| s.gpu.tiles as f64) / 1000.0,
            );
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Whether `path` looks usable as a benchmark input.
fn check_input(path: &str) -> anyhow::Result<()> {
    if !Path::new(path).is_file() {
        bail!("cannot open input '{path}': no such file");
    }
    Ok(())
}

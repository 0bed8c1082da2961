//! The `rain-composite` command line: flags → library calls → stdout/stderr. anyhow lives only
//! here.
//!
//! - `args`: the flags (clap) and their translation into the library's settings.
//! - `flags`: the table of the settings' keys and their flags.
//! - `messages`: the library's errors and warnings in the command line's words (flags).
//! - `inspect`: the `inspect` subcommands, printing the library's reports.
//! - `bench`: speed against a plain ffmpeg transcode.

use std::io::IsTerminal;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, bail};
use rain_composite::fluid::puddles::Checkpoints;
use rain_composite::gpu::list_adapters;
use rain_composite::pipeline::{self, FrameSelector, Job, Progress};
use rain_composite::video;

use args::{Bits, Cli, Command, ConfigArgs, PreviewArgs, ProgressMode, RenderArgs};
use args::{adapter, encode_options, parse_time_s, render_config};

mod args;
mod bench;
mod drops;
mod flags;
mod inspect;
mod messages;

/// Set by Ctrl-C, TERM and HUP: every long loop polls it and stops cleanly.
pub(crate) static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Our messages at the chosen level; other crates' (wgpu, naga) only at `-vv`, and then only
/// their warnings and errors.
struct StderrLogger {
    level: log::LevelFilter,
    third_party: bool,
}

impl log::Log for StderrLogger {
    fn enabled(&self, m: &log::Metadata) -> bool {
        if m.target().starts_with("rain_composite") {
            m.level() <= self.level
        } else {
            self.third_party && m.level() <= log::Level::Warn
        }
    }
    fn log(&self, r: &log::Record) {
        if self.enabled(r.metadata()) {
            let tag = match r.level() {
                log::Level::Error => "error",
                log::Level::Warn => "warning",
                log::Level::Info => "info",
                _ => "debug",
            };
            // The library names settings by key; the user reads their flags.
            eprintln!("{tag}: {}", flags::in_prose(&r.args().to_string()));
        }
    }
    fn flush(&self) {}
}

fn run_render(args: &RenderArgs) -> anyhow::Result<()> {
    let Some(input) = args.input.clone() else {
        bail!("no input given (usage: rain-composite INPUT -o OUTPUT; see --help)");
    };
    let Some(output) = args.output.clone() else {
        bail!("no output given: add -o OUTPUT (or -o - for stdout)");
    };
    let render = render_config(&args.look)?;
    let encode = encode_options(&args.encode, args.overwrite)?;
    let job = Job {
        input: input.clone(),
        output: output.clone(),
        render,
        encode,
        adapter: adapter(&args.gpu),
        frames: args::frame_range(args)?,
        checkpoints: Some(Checkpoints {
            dir: args.checkpoints.dir(&input, &output),
            every_frames: args.checkpoint_every,
        }),
    };
    let bar = (args.progress == ProgressMode::Auto && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new(0);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} frames  {per_sec}  ETA {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar
    });
    let json = args.progress == ProgressMode::Json;
    let mut report = |p: Progress| {
        if let Some(bar) = &bar {
            if let Some(total) = p.frames_total {
                bar.set_length(total);
            }
            bar.set_position(p.frames_done);
        } else if json {
            if let Ok(line) = serde_json::to_string(&p) {
                eprintln!("{line}");
            }
        }
    };
    let summary = pipeline::render(&job, &INTERRUPTED, &mut report)?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    log::info!(
        "{} frames in {:.2} s ({:.1} fps) on {}, {} drops per frame",
        summary.frames,
        summary.elapsed_s,
        summary.frames as f64 / summary.elapsed_s.max(1e-9),
        summary.adapter,
        summary.drops
    );
    if json {
        eprintln!("{}", serde_json::to_string(&summary)?);
    }
    Ok(())
}

fn run_preview(args: &PreviewArgs) -> anyhow::Result<()> {
    let to_stdout = args.output == "-";
    if !to_stdout {
        let is_png = std::path::Path::new(&args.output)
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"));
        if !is_png {
            bail!(
                "output '{}': preview writes PNG, give a name ending in .png (or - for stdout)",
                args.output
            );
        }
        video::check_output(&args.output, &[&args.input], args.overwrite)?;
    }
    let at = match (&args.at, args.frame) {
        (Some(t), _) => FrameSelector::At(parse_time_s(t)?),
        (None, Some(n)) => FrameSelector::Index(n),
        (None, None) => bail!("give --at TIME or --frame N"),
    };
    let render = render_config(&args.look)?;
    let checkpoints = Checkpoints {
        dir: args.checkpoints.dir(&args.input, &args.input),
        every_frames: 0,
    };
    let (frame, info) = pipeline::preview(
        &args.input,
        at,
        &render,
        &adapter(&args.gpu),
        Some(&checkpoints),
        &INTERRUPTED,
    )?;
    let bits = if args.bits == Bits::Sixteen { 16 } else { 8 };
    let png = video::still::encode_png(&frame, info.rotation_deg, bits)?;
    if to_stdout {
        use std::io::Write;
        let mut stdout = std::io::stdout().lock();
        return stdout
            .write_all(&png)
            .and_then(|()| stdout.flush())
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::BrokenPipe => {
                    anyhow::anyhow!("stdout was closed before the PNG was complete")
                }
                _ => anyhow::anyhow!("cannot write the PNG to stdout: {e}"),
            });
    }
    // Written beside under a hidden name, then renamed: never a half-written PNG, and nothing
    // left behind when writing fails.
    let tmp = video::TempFile::beside(std::path::Path::new(&args.output));
    std::fs::write(tmp.path(), &png)
        .with_context(|| format!("cannot write output '{}'", args.output))?;
    tmp.publish()?;
    Ok(())
}

/// `config --print`: the effective configuration; `config --list`: the presets.
fn run_config(args: &ConfigArgs) -> anyhow::Result<()> {
    if args.list {
        for p in rain_composite::preset::PRESETS {
            out(&format!("{:<14} {}", p.name, p.description()))?;
        }
        return Ok(());
    }
    out(&serde_json::to_string_pretty(
        &render_config(&args.look)?.to_value(),
    )?)
}

/// One line (or block) on stdout. A closed pipe (`| head`) ends the output quietly.
pub(crate) fn out(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{text}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r.context("writing to stdout"),
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match &cli.command {
        None => run_render(&cli.render),
        Some(Command::Preview(p)) => run_preview(p),
        Some(Command::Probe(p)) => {
            let report = video::probe(&p.input, p.for_output.as_deref())?;
            if p.json {
                out(&serde_json::to_string_pretty(&report)?)?;
            } else {
                out(report.to_string().trim_end())?;
            }
            Ok(())
        }
        Some(Command::Inspect(i)) => inspect::run(i),
        Some(Command::Drops(d)) => drops::run(d),
        Some(Command::Config(c)) => run_config(c),
        Some(Command::Completions { shell }) => {
            let mut command = args::command();
            let mut script = Vec::new();
            clap_complete::generate(*shell, &mut command, "rain-composite", &mut script);
            out(String::from_utf8_lossy(&script).trim_end())
        }
        Some(Command::Man) => {
            let mut page = Vec::new();
            clap_mangen::Man::new(args::command()).render(&mut page)?;
            out(String::from_utf8_lossy(&page).trim_end())
        }
        Some(Command::Bench(b)) => bench::run_command(b),
        Some(Command::Adapters { json }) => {
            let adapters = list_adapters();
            if *json {
                out(&serde_json::to_string_pretty(&adapters)?)?;
            } else if adapters.is_empty() {
                bail!(
                    "no GPU adapter found (install a Vulkan driver, or mesa-vulkan-drivers for the CPU one)"
                );
            } else {
                for a in adapters {
                    out(&format!(
                        "{:<40} {:<8} {:<14} {}",
                        a.name, a.backend, a.device_type, a.driver
                    ))?;
                }
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // Mesa's device-select Vulkan layer connects to a Wayland display to order the GPUs,
        // and libwayland prints "error: XDG_RUNTIME_DIR is invalid or not set" on stderr when
        // there is none (a server, CI, ssh), which reads as a failure. We rank adapters
        // ourselves, so the layer has nothing to add.
        // SAFETY: no other thread exists yet; nothing reads the environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    let cli = args::parse();
    let level = match (cli.log.quiet, cli.log.verbose) {
        (true, _) => log::LevelFilter::Error,
        (false, 0) => log::LevelFilter::Warn,
        (false, 1) => log::LevelFilter::Info,
        _ => log::LevelFilter::Debug,
    };
    let third_party = !cli.log.quiet && cli.log.verbose >= 2;
    if log::set_logger(Box::leak(Box::new(StderrLogger { level, third_party }))).is_ok() {
        log::set_max_level(level);
    }
    if third_party {
        video::set_ffmpeg_log_level(ffmpeg_next::util::log::Level::Warning);
    }
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::Relaxed));
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", messages::for_user(&e));
            ExitCode::FAILURE
        }
    }
}

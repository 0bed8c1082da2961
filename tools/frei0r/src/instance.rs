//! One plug-in instance: a frame size, the parameters, and the [`Renderer`] built from them
//! at the first frame (and again whenever a parameter that changes the rain's plan changes).

use rain_composite::Renderer;
use rain_composite::Result;
use rain_composite::config::RenderConfig;
use rain_composite::gpu::AdapterRequest;
use rain_composite::shot::Footage;
use rain_composite::video::rgba::{
    RGBA8_COLOR, planes_from_rgba8, rgba8_format, rgba8_from_planes,
};

use crate::clock::{Clock, host_unit_s};
use crate::params::Params;

/// What a renderer is built from: two equal plans render the same pictures.
#[derive(Debug, Clone, PartialEq)]
struct Plan {
    config: RenderConfig,
    fps: f64,
}

/// The renderer, or why there is none for this plan (kept, so a plan that fails is not
/// rebuilt at every frame).
enum Built {
    Ready(Box<Renderer>),
    Failed(String),
}

/// One instance: what `f0r_construct` returns a pointer to.
pub struct Instance {
    width: u32,
    height: u32,
    /// The parameters as the host set them.
    pub params: Params,
    built: Option<(Plan, Built)>,
    clock: Clock,
}

/// What one frame's update did, for the host's log.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Rain drawn at this shot time.
    Rendered {
        /// Seconds of the shot.
        t_s: f64,
        /// The host's time was not a time; the clock counted frames.
        fallback: bool,
    },
    /// The input passed through, and why.
    PassedThrough(String),
}

impl Instance {
    /// An instance for frames of `width`×`height`; nothing is built until the first frame.
    pub fn new(width: u32, height: u32) -> Instance {
        Instance {
            width,
            height,
            params: Params::default(),
            built: None,
            clock: Clock::default(),
        }
    }

    /// Drops the renderer (after a panic left it in an unknown state); the next frame builds
    /// a new one.
    pub fn reset(&mut self) {
        self.built = None;
    }

    /// Bytes of one frame.
    pub fn frame_bytes(&self) -> usize {
        self.width as usize * self.height as usize * 4
    }

    /// Renders `input` (RGBA, the instance's size) at the host's time `host_time` into
    /// `output`; on any error the input passes through and the outcome says why.
    pub fn update(&mut self, host_time: f64, input: &[u8], output: &mut [u8]) -> Outcome {
        match self.render(host_time, input, output) {
            Ok(outcome) => outcome,
            Err(why) => {
                if output.len() == input.len() {
                    output.copy_from_slice(input);
                }
                Outcome::PassedThrough(why)
            }
        }
    }

    /// The frame with rain, or why not (a message for the host's log).
    fn render(
        &mut self,
        host_time: f64,
        input: &[u8],
        output: &mut [u8],
    ) -> std::result::Result<Outcome, String> {
        let (width, height) = (self.width, self.height);
        let time = self.clock.shot_time(host_time, host_unit_s(), &self.params);
        let renderer = self.renderer()?;
        let wet = planes_from_rgba8(input, width, height)
            .and_then(|frame| renderer.render(&frame, time.t_s))
            .and_then(|wet| rgba8_from_planes(&wet, input, output))
            .map_err(|e| e.to_string());
        wet?;
        Ok(Outcome::Rendered {
            t_s: time.t_s,
            fallback: time.fallback,
        })
    }

    /// The renderer of the current parameters, built (or rebuilt) when their plan changed.
    fn renderer(&mut self) -> std::result::Result<&mut Renderer, String> {
        let plan = Plan {
            config: self.params.config().map_err(|e| e.to_string())?,
            fps: self.params.fps(),
        };
        if self.built.as_ref().is_none_or(|(built, _)| *built != plan) {
            // The old renderer goes first: two GPU contexts at once only cost memory.
            self.built = None;
            let built = match self.build(&plan) {
                Ok(r) => {
                    if crate::tracing() {
                        eprintln!(
                            "rain-composite (frei0r): {}x{} on {}, {} drops a frame",
                            self.width,
                            self.height,
                            r.adapter(),
                            r.drop_count()
                        );
                    }
                    Built::Ready(Box::new(r))
                }
                Err(e) => Built::Failed(e.to_string()),
            };
            self.built = Some((plan, built));
        }
        match &mut self.built {
            Some((_, Built::Ready(r))) => Ok(r),
            Some((_, Built::Failed(why))) => Err(why.clone()),
            None => Err("no renderer was built".into()),
        }
    }

    fn build(&self, plan: &Plan) -> Result<Renderer> {
        let footage =
            Footage::picture(rgba8_format(self.width, self.height), RGBA8_COLOR, plan.fps);
        let adapter = AdapterRequest {
            name: std::env::var("RAIN_COMPOSITE_ADAPTER").ok(),
            ..AdapterRequest::default()
        };
        // The frames are 8-bit pictures in 16-bit planes: clipping is judged in 8-bit codes.
        Ok(Renderer::new(&plan.config, &footage, &adapter)?.with_source_bits(8))
    }
}

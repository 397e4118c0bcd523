//! The stages a run reports its progress in, in order, and the time each step took.

use std::time::{Duration, Instant};

use super::StageParams;
use crate::imprecision;

/// A stage of a run, as the progress output names it (`PROGRESS <fraction> <name>`): the
/// Blender add-on reads these names from `cubist settings --schema`, never from a copy.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    Loading,
    PreRender,
    Saliency,
    Faceting,
    Imprecision,
    ReTrace,
    AntiAliasing,
    Paint,
    Writing,
    Done,
}

impl Stage {
    /// Every stage in the order a render runs them.
    pub const ALL: [Stage; 10] = [
        Stage::Loading,
        Stage::PreRender,
        Stage::Saliency,
        Stage::Faceting,
        Stage::Imprecision,
        Stage::ReTrace,
        Stage::AntiAliasing,
        Stage::Paint,
        Stage::Writing,
        Stage::Done,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::Loading => "loading",
            Stage::PreRender => "pre-render",
            Stage::Saliency => "saliency",
            Stage::Faceting => "faceting",
            Stage::Imprecision => "imprecision",
            Stage::ReTrace => "re-trace",
            Stage::AntiAliasing => "anti-aliasing",
            Stage::Paint => "paint",
            Stage::Writing => "writing",
            Stage::Done => "done",
        }
    }

    /// What the stage does, in a line.
    pub fn help(self) -> &'static str {
        match self {
            Stage::Loading => "reading the scene and building its BVH",
            Stage::PreRender => "one trace of the whole image: colour and every hit buffer",
            Stage::Saliency => "mesh saliency of the meshes in view and the per-pixel saliency map",
            Stage::Faceting => "the facet layout: computed (Segment: from the pre-render) or loaded",
            Stage::Imprecision => "facet and saliency centres, and where each facet is re-aimed or turned",
            Stage::ReTrace => "tracing again the pixels of facets whose rays moved",
            Stage::AntiAliasing => "more samples for the pixels whose neighbours disagree (all: aa_threshold 0)",
            Stage::Paint => "the painterly effects",
            Stage::Writing => "writing the image and its passes",
            Stage::Done => "finished",
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which of the optional stages a render runs, decided from its parameters alone (the
/// pre-render, encoding and writing always run). The render follows this plan, and
/// `cubist settings --stages` prints it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    /// Mesh saliency and the saliency map: some later stage reads them.
    pub saliency: bool,
    /// A facet layout: computed or loaded.
    pub faceting: bool,
    /// Re-aiming facets (and re-tracing those whose rays moved).
    pub imprecision: bool,
    /// More than one sample per pixel: the anti-aliasing stage.
    pub antialiasing: bool,
    /// Some painterly effect is on.
    pub paint: bool,
}

impl Plan {
    pub fn new(params: &StageParams) -> Plan {
        let faceting = params.facets.faceted();
        Plan {
            saliency: params.needs_saliency(),
            faceting,
            imprecision: faceting && imprecision::changes_rays(&params.aim),
            antialiasing: params.trace.spp > 1,
            paint: !params.paint.is_off(),
        }
    }

    /// The stages a render runs, in order. `re-trace` is listed with `imprecision`: it runs
    /// when some facet's rays moved, which only the aims tell.
    pub fn stages(&self) -> Vec<Stage> {
        let optional = [
            (Stage::Saliency, self.saliency),
            (Stage::Faceting, self.faceting),
            (Stage::Imprecision, self.imprecision),
            (Stage::ReTrace, self.imprecision),
            (Stage::AntiAliasing, self.antialiasing),
            (Stage::Paint, self.paint),
        ];
        let mut stages = vec![Stage::Loading, Stage::PreRender];
        stages.extend(optional.into_iter().filter(|(_, on)| *on).map(|(s, _)| s));
        stages.extend([Stage::Writing, Stage::Done]);
        stages
    }
}

/// Named step durations, in the order they ran (`--verbose`): the stages' names, and steps
/// within or beside them ("paint setup", "encode"). The second list holds each step's CPU
/// time, every thread of the process counted (where Linux tells it), in the same order: on
/// a shared machine it is the stable measure.
/// The timing entry of mesh saliency run beside framing and the pre-render: its wall time,
/// not part of the sequence (totals leave it out), no CPU figure of its own.
pub const MESH_SALIENCY_OVERLAPPED: &str = "mesh saliency (overlapped)";

#[derive(Clone, Debug, Default)]
pub struct Timings(pub Vec<(&'static str, Duration)>, pub Vec<Option<Duration>>);

impl Timings {
    pub fn time<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let (t, c) = (Instant::now(), process_cpu());
        let r = f();
        self.0.push((name, t.elapsed()));
        self.1.push(c.zip(process_cpu()).map(|(a, b)| b.saturating_sub(a)));
        r
    }

    /// The wall time of the steps run one after another (the overlapped ones left out).
    pub fn sequential_total(&self) -> Duration {
        self.0.iter().filter(|(n, _)| *n != MESH_SALIENCY_OVERLAPPED).map(|(_, t)| *t).sum()
    }

    /// The CPU time of step `i`, if known.
    pub fn cpu(&self, i: usize) -> Option<Duration> {
        self.1.get(i).copied().flatten()
    }
}

/// CPU time used so far by every live thread of this process (rayon's pool threads live as
/// long as it does), from /proc/self/task/*/schedstat, nanoseconds. None off Linux.
pub fn process_cpu() -> Option<Duration> {
    let mut total = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(Duration::from_nanos(total))
}

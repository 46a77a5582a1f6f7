//! The frame plan: what one frame runs, decided once when a
//! [`Renderer`](crate::Renderer) is made, from the method, the scene, the
//! backend and the options.
//!
//! A plan is an ordered list of [`Stage`]s: the method that fills the
//! G-buffer, then the passes. Each stage says which G-buffer channels it
//! reads and writes, the buffers it owns and the side it runs on. On the
//! GPU backend the passes that have a GPU implementation run there, in
//! order, from the first one on; the first pass that has only a CPU
//! implementation forces the read-back, and it and every pass after it run
//! on the CPU. The plan says where the read-back falls and what it carries.
//! `Renderer::render` walks the same lists the plan is printed from
//! (`Renderer::explain`), so the description cannot drift from what runs.

use std::fmt;

/// A set of G-buffer channels ([`raycast::Frame`]'s buffers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct Channels(u8);

impl Channels {
    /// Nothing.
    pub const NONE: Channels = Channels(0);
    /// The 8-bit colour.
    pub const COLOUR: Channels = Channels(1);
    /// Whether a pixel's ray hit.
    pub const HIT: Channels = Channels(1 << 1);
    /// Eye distance, mm.
    pub const DEPTH: Channels = Channels(1 << 2);
    /// Object id.
    pub const ID: Channels = Channels(1 << 3);
    /// Surface normal.
    pub const NORMAL: Channels = Channels(1 << 4);
    /// The hybrid method's per-pixel layer (cast, interpolated, refined).
    pub const LAYER: Channels = Channels(1 << 5);
    /// The surface buffers a method fills only when a stage reads them.
    pub const SURFACE: Channels = Channels(Self::DEPTH.0 | Self::ID.0 | Self::NORMAL.0);
    /// Every channel.
    pub const ALL: Channels = Channels(63);

    const NAMES: [(&'static str, Channels); 6] = [
        ("colour", Self::COLOUR),
        ("hit", Self::HIT),
        ("depth", Self::DEPTH),
        ("id", Self::ID),
        ("normal", Self::NORMAL),
        ("layer", Self::LAYER),
    ];

    /// Both sets.
    pub const fn union(self, other: Channels) -> Channels {
        Channels(self.0 | other.0)
    }

    /// Whether the sets share a channel.
    pub const fn intersects(self, other: Channels) -> bool {
        self.0 & other.0 != 0
    }

    /// Whether every channel of `other` is in `self`.
    pub const fn contains(self, other: Channels) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }
}

impl std::ops::BitOr for Channels {
    type Output = Channels;
    fn bitor(self, rhs: Channels) -> Channels {
        self.union(rhs)
    }
}

impl fmt::Display for Channels {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("nothing");
        }
        let names: Vec<&str> = Self::NAMES
            .iter()
            .filter(|(_, c)| self.contains(*c))
            .map(|(n, _)| *n)
            .collect();
        f.write_str(&names.join(", "))
    }
}

/// Where a stage runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Side {
    /// On the CPU.
    Cpu,
    /// On the GPU.
    Gpu,
}

impl Side {
    /// `"cpu"` or `"gpu"`.
    pub fn name(self) -> &'static str {
        match self {
            Side::Cpu => "cpu",
            Side::Gpu => "gpu",
        }
    }
}

/// What a stage is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    /// Fills the G-buffer (the method's cast or raster).
    Method,
    /// A pass that belongs to the method (image-based foveation's blur):
    /// its time is the method's.
    MethodPass,
    /// An effect pass the scene (or an option) asks for.
    Effect,
}

/// One stage of a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// The stage's name (the method's or the pass's), as `explain` shows it.
    pub name: String,
    /// What kind of stage it is.
    pub role: Role,
    /// Where it runs.
    pub side: Side,
    /// The G-buffer channels it reads.
    pub reads: Channels,
    /// The G-buffer channels it writes.
    pub writes: Channels,
    /// The buffers the stage allocates (with its first frame), in words.
    pub owns: String,
    /// What it does, for `explain`.
    pub detail: String,
}

/// A frame's stages in order, and where the frame comes back to the CPU.
#[derive(Debug, Clone, PartialEq)]
pub struct FramePlan {
    /// The method's name (`Method::name`).
    pub method: &'static str,
    /// The backend: `cpu` or `gpu`.
    pub backend: Side,
    /// The stages, in order: the method first, then its passes.
    pub stages: Vec<Stage>,
    /// The finished frame stays on the GPU, drawn into the window there
    /// (`Renderer::set_stay_on_gpu`): no read-back.
    pub stays_on_gpu: bool,
}

impl FramePlan {
    /// The passes (not the method), in order.
    pub fn passes(&self) -> impl Iterator<Item = &Stage> {
        self.stages.iter().filter(|s| s.role != Role::Method)
    }

    /// On the GPU backend: the index of the first stage that runs on the
    /// CPU (the read-back falls before it; `stages.len()` when every stage
    /// runs on the GPU) and the channels the read-back carries: colour and
    /// hit always (the frame is returned), plus what the CPU stages read.
    /// `None` on the CPU backend.
    pub fn readback(&self) -> Option<(usize, Channels)> {
        if self.backend == Side::Cpu || self.stays_on_gpu {
            return None;
        }
        let at = self
            .stages
            .iter()
            .position(|s| s.side == Side::Cpu)
            .unwrap_or(self.stages.len());
        let reads = self.stages[at..]
            .iter()
            .fold(Channels::COLOUR | Channels::HIT, |c, s| c | s.reads);
        Some((at, reads))
    }

    /// One line for every frame's record: the method, the backend and the
    /// passes in order with where each runs. No tabs or line breaks.
    pub fn provenance(&self) -> String {
        let passes: Vec<String> = self
            .passes()
            .map(|s| format!("{} ({})", s.name, s.side.name()))
            .collect();
        format!(
            "{} on {}; passes: {}{}",
            self.method,
            self.backend.name(),
            if passes.is_empty() {
                "none".to_string()
            } else {
                passes.join(" → ")
            },
            if self.stays_on_gpu {
                "; no read-back (drawn into the window on the GPU)"
            } else {
                ""
            }
        )
    }

    /// The plan as `explain` prints it: one line per stage with what it
    /// reads, writes and owns, and the read-back where it falls.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![format!(
            "frame plan ({} stage{}):",
            self.stages.len(),
            if self.stages.len() == 1 { "" } else { "s" }
        )];
        let readback = self.readback();
        for (i, s) in self.stages.iter().enumerate() {
            if let Some((at, carries)) = readback {
                if at == i {
                    out.push(format!(
                        "  read-back to the CPU ({carries}): the stages after it have no GPU \
                         implementation"
                    ));
                }
            }
            out.push(format!(
                "  {}. {} [{}] reads {}; writes {}; owns {}",
                i + 1,
                s.name,
                s.side.name(),
                s.reads,
                s.writes,
                s.owns
            ));
        }
        if let Some((at, carries)) = readback {
            if at == self.stages.len() {
                out.push(format!("  read-back of the finished frame ({carries})"));
            }
        }
        if self.stays_on_gpu {
            out.push(
                "  no read-back: the finished frame is drawn into the window on the GPU".into(),
            );
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stage(name: &str, role: Role, side: Side, reads: Channels) -> Stage {
        Stage {
            name: name.into(),
            role,
            side,
            reads,
            writes: Channels::COLOUR,
            owns: "nothing".into(),
            detail: String::new(),
        }
    }

    #[test]
    fn channels_print_and_combine() {
        assert_eq!(Channels::NONE.to_string(), "nothing");
        assert_eq!(
            (Channels::COLOUR | Channels::DEPTH).to_string(),
            "colour, depth"
        );
        assert!(Channels::SURFACE.contains(Channels::ID));
        assert!(!Channels::SURFACE.intersects(Channels::COLOUR));
        assert_eq!(
            Channels::ALL.to_string(),
            "colour, hit, depth, id, normal, layer"
        );
    }

    #[test]
    fn the_read_back_falls_before_the_first_cpu_stage() {
        let plan = FramePlan {
            method: "full",
            backend: Side::Gpu,
            stays_on_gpu: false,
            stages: vec![
                stage("cast", Role::Method, Side::Gpu, Channels::NONE),
                stage("a", Role::Effect, Side::Gpu, Channels::DEPTH),
                stage("b", Role::Effect, Side::Cpu, Channels::ID),
                stage("c", Role::Effect, Side::Cpu, Channels::COLOUR),
            ],
        };
        let (at, carries) = plan.readback().expect("gpu");
        assert_eq!(at, 2);
        assert_eq!(carries, Channels::COLOUR | Channels::HIT | Channels::ID);
        let text = plan.lines().join("\n");
        assert!(
            text.contains("read-back to the CPU (colour, hit, id)"),
            "{text}"
        );
        assert_eq!(
            plan.provenance(),
            "full on gpu; passes: a (gpu) → b (cpu) → c (cpu)"
        );
        let cpu = FramePlan {
            backend: Side::Cpu,
            stays_on_gpu: false,
            stages: vec![stage("cast", Role::Method, Side::Cpu, Channels::NONE)],
            ..plan
        };
        assert!(cpu.readback().is_none());
        assert_eq!(cpu.provenance(), "full on cpu; passes: none");
    }
}

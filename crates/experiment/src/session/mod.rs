//! The session folder: one folder per participant session, written by the
//! runner as the session happens and read back by the analysis
//! ([`crate::analysis`]) and the BIDS export ([`crate::bids`]).
//!
//! ```text
//! <session>/
//!   session.json          SessionInfo (who, what design, which display and tracker)
//!   design.ron            a copy of the design file (Design::load)
//!   trials.tsv            TrialRow, one per completed trial (with its plan)
//!   samples.tsv           SampleRow, every gaze sample
//!   events.tsv            EventRow, fixations / saccades / blinks
//!   markers.tsv           MarkerRow, phase starts, keys, clicks, calibration results
//!   frames.tsv            FrameRow, every frame shown (with the plan that drew it)
//!   clock.tsv             ClockRow, the tracker clock model as it was updated
//!   gaze-N.gzrec          every tracker byte of sitting N, with arrival times
//!   stimuli/trial-NNN.png the search display of trial NNN (optional, RGB)
//! ```
//!
//! # Clocks and sittings
//!
//! Every time in these files says its clock in its name and its column's
//! doc. Two clocks appear:
//!
//! - the **host clock** (`*_us` without `device`): the runner's monotonic
//!   microseconds, restarted by each process — so every row also carries
//!   its `sitting` (1, 2, … : one per run of `experiment run`, the first
//!   and each `--resume`). [`Sitting`] in `session.json` ties each
//!   sitting's host clock to the wall clock (`started_unix_us` at
//!   `host_anchor_us`), which puts all sittings on one time axis
//!   ([`SessionInfo::session_time_us`]).
//! - the **tracker clock** (`device_us`): the tracker's own timestamps as
//!   decoded (how they are derived: [`Sitting::device_clock`]).
//!
//! A gaze sample's `mapped_us` is its device time mapped onto the host
//! clock by tracker-hal's clock model (its updates: `clock.tsv`); events,
//! trial-relative times and the BIDS export use it. Its `arrival_us` is
//! when its bytes arrived (what machine load changes): kept, never used
//! for timing.
//!
//! A trial interrupted by the end of a sitting (a crash, Esc,
//! `--max-trials`) is run again in the next one: its samples in the
//! earlier sitting are *aborted* ([`aborted`]) and left out of the
//! analysis and the export.
//!
//! # Provenance: the `plan` columns
//!
//! Every frame says what drew it, so that a lab can show what each
//! condition rendered: `frames.tsv`'s `plan` is the provenance line of the
//! renderer that drew the frame (`pipeline::Renderer::provenance`: the
//! method that ran, the backend, and the passes in order with where each
//! ran), e.g. `image on gpu; passes: image-based foveation (gpu)` or
//! `hybrid on cpu; passes: none`; `n/a` for a screen no renderer drew
//! (text, calibration targets). `trials.tsv`'s `plan` is the plan of the
//! trial's search frames (the condition's renderer). The line never holds
//! a tab or a line break, and is never empty or `n/a` itself.
//!
//! The column came after the files' first version: a file written before
//! it has a header that stops short of it ([`TsvRow::LATER_COLUMNS`]).
//! Such a file is read with `plan` missing (`None`), and a sitting resumed
//! on it first adds the column (`n/a` in the earlier rows) — see
//! [`read_tsv`] and [`TsvLog::append_to`].
//!
//! # The TSV files
//!
//! Tab-separated, one header line naming the columns ([`TsvRow::COLUMNS`],
//! in struct field order), `\n` line ends, no quoting at all (as BIDS
//! TSV): a field is the bytes between two tabs. A missing value
//! (`Option::None`) is written `n/a`, as BIDS does; on reading, `n/a` or
//! an empty field is `None`. Booleans are `true` / `false`; numbers are
//! written in the shortest form that reads back to the same bits
//! (`0.1`, `1e-300`, `1.7976931348623157e308`; NaN and infinities as `NaN`,
//! `inf`, `-inf`), so every row round-trips exactly.
//!
//! Text fields may hold anything except a tab, a carriage return or a line
//! feed: with no quoting those would split the field or the row, so
//! [`TsvLog::write`] **rejects** such a row with an error naming the
//! column, rather than escaping it (an escape would be one more private
//! convention every other TSV reader would get wrong). Quote characters,
//! spaces, `n/a` itself and any other Unicode are kept as they are.
//!
//! # Durability policy of [`TsvLog`]
//!
//! Each [`TsvLog::write`] formats the whole row in memory first and hands
//! the OS complete lines only, in one `write` call per flush. By default
//! every row is flushed at once, so a process that is killed (even with
//! `SIGKILL`) loses nothing it had written: the rows are in the OS page
//! cache. [`TsvLog::flush_every`] batches rows for high-rate files
//! (samples at 1 kHz): rows are then handed to the OS when `rows` are
//! pending or `interval` has passed since the last flush, *checked at each
//! write*, so a killed process loses at most those pending rows. Dropping
//! the log flushes. [`TsvLog::sync`] additionally asks the OS to put the
//! data on disk (`fsync`), which protects against power loss; call it at
//! trial ends, not per row.
//!
//! A process killed in the middle of the OS `write` can still leave a
//! half-written last line. [`read_tsv`] reports such a line (any last line
//! without its `\n`) as a [`ReadWarning`] and skips it; reopening the file
//! with [`TsvLog::append_to`] cuts it off before appending (and says so in
//! [`TsvLog::dropped_partial_line`]).
//!
//! `session.json` and every output of the analysis are written through
//! [`AtomicFile`]: a temporary file in the same folder, renamed over the
//! target once complete, so a reader never sees half a file.

mod atomic;
mod de;
mod error;
mod info;
mod layout;
pub mod na;
mod rows;
mod tsv_log;
mod tsv_read;

pub use atomic::*;
pub use error::*;
pub use info::*;
pub use layout::*;
pub use rows::*;
pub use tsv_log::*;
pub use tsv_read::*;

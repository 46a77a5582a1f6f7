//! Timestamp queries around each compute pass, where the adapter has them.

use super::foveated::Stage;
use super::readback::read_back;
use super::{GpuError, TrafficCounter};

/// A query set with two timestamps (begin, end) per pass, its resolve
/// buffer and a readback buffer.
#[derive(Clone)]
pub(super) struct Timer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f32,
}

impl Timer {
    /// Room for the most passes a frame runs (every foveated stage).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        let n = 2 * Stage::ALL.len() as u32;
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("stage times"),
            ty: wgpu::QueryType::Timestamp,
            count: n,
        });
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 8 * u64::from(n),
                usage,
                mapped_at_creation: false,
            })
        };
        Self {
            set,
            resolve: buffer(
                "stage times",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: buffer(
                "stage times readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            period_ns: queue.get_timestamp_period(),
        }
    }

    /// Resolves the timestamps of the first `passes` passes into the
    /// readback buffer.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder, passes: u32) {
        encoder.resolve_query_set(&self.set, 0..2 * passes, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16 * u64::from(passes));
    }

    /// The time of each pass (ms), named `names` in pass order, after the
    /// submission that resolved them.
    pub fn read(
        &self,
        device: &wgpu::Device,
        traffic: &TrafficCounter,
        names: &[&'static str],
    ) -> Result<Vec<(&'static str, f64)>, GpuError> {
        let words = read_back(device, traffic, &self.readback, 16 * names.len() as u64)?;
        let tick = |k: usize| u64::from(words[2 * k]) | (u64::from(words[2 * k + 1]) << 32);
        Ok(names
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let ticks = tick(2 * k + 1).saturating_sub(tick(2 * k));
                (*s, ticks as f64 * f64::from(self.period_ns) * 1e-6)
            })
            .collect())
    }
}

/// Begins compute pass number `pass` of the frame, timed when there is a
/// timer.
pub(super) fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    timer: Option<&Timer>,
    pass: u32,
    label: &str,
) -> wgpu::ComputePass<'e> {
    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: timer.map(|t| wgpu::ComputePassTimestampWrites {
            query_set: &t.set,
            beginning_of_pass_write_index: Some(2 * pass),
            end_of_pass_write_index: Some(2 * pass + 1),
        }),
    })
}

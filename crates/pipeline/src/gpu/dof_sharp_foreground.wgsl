// Depth of field without foreground smoothing: the hooks that
// `dof_foreground.wgsl` fills do nothing (no buffer is bound).
fn note_level(i: u32, hit: bool) {}

fn override_level(i: u32) -> f32 {
    return -1.0;
}

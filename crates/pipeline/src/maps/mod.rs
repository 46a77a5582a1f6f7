//! Debug maps: each file here is one per-pixel quantity drawn as a picture
//! (`gazecast render --map NAME=FILE.png`), declaring its `MAP`
//! ([`crate::registry::DebugMap`]); the one line below registers it.

macro_rules! register {
    ($($module:ident),* $(,)?) => {
        $(pub mod $module;)*
        /// The registered debug maps, in `--help` order.
        pub static ALL: &[&crate::registry::DebugMap] = &[$(&$module::MAP),*];
    };
}

register!(eccentricity, cutoff);

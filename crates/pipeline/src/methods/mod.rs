//! Method modules: each file here is one rendering method
//! ([`crate::registry::FrameMethod`] and its `METHOD` registration), and
//! the one line below registers it — a new method is its file and its
//! name in that line.

macro_rules! register {
    ($($module:ident),* $(,)?) => {
        $(pub mod $module;)*
        /// The registered method modules, in `--help` order.
        pub static ALL: &[&crate::registry::MethodModule] = &[$(&$module::METHOD),*];
    };
}

register!(layers);

//! Rendering methods, one file each: the built-in ones (each a named
//! [`crate::Method`] variant whose [`crate::Method::module`] is here) and
//! the registered modules. Each file declares its `METHOD: MethodModule`
//! (names, help, properties, how its state is made) and implements
//! [`crate::registry::FrameMethod`] for its state. A new method is its
//! file and its name in the `register!` line below.

mod cast;

// The built-in methods (the `Method` enum names them).
pub mod full;
pub mod hybrid;
pub mod image;
pub mod lod;
pub mod simplify;
pub mod ulod;

macro_rules! register {
    ($($module:ident),* $(,)?) => {
        $(pub mod $module;)*
        /// The registered method modules, in `--help` order.
        pub static ALL: &[&crate::registry::MethodModule] = &[$(&$module::METHOD),*];
    };
}

register!(layers);

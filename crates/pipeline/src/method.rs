//! Rendering methods: what fills the G-buffer, and the one place a method
//! is chosen — by name ([`Method::from_name`]: the command line, an
//! experiment condition, a bench configuration) and for a scene
//! ([`Method::for_scene`]).

use std::fmt;
use std::str::FromStr;

use raycast::Scene;

use crate::registry::{MethodModule, METHODS};

/// How a frame's G-buffer is filled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// One ray per pixel (the control condition).
    Full,
    /// Murphy 2007's hybrid: the CSF ray mask, reconstruction from the
    /// intermediate mesh, refinement where the scene's effects ask.
    #[default]
    Hybrid,
    /// Image-based foveation (Geisler & Perry 1998): every pixel cast, then
    /// blurred by a Gaussian pyramid to the level the CSF allows at its
    /// eccentricity.
    Image,
    /// Model-based: Luebke & Hallen 2001's perceptual simplification
    /// (imperceptible mode: every fold the Geisler–Perry table judges
    /// invisible at its eccentricity), rasterised.
    Simplify,
    /// Model-based: Murphy & Duchowski 2001's gaze-contingent level of
    /// detail (Table 1's levels by eccentricity), rasterised.
    Lod,
    /// Lee 2009 ch. 7: attention-guided level of detail with ULOD's blend
    /// of adjacent levels, levels set by Lee's attention model on the
    /// previous frame; no eye tracker needed. CPU raster.
    Ulod,
    /// A method module registered in [`crate::registry::METHODS`].
    Module(&'static MethodModule),
}

/// The built-in methods, in `--help` order; each is a module in
/// [`crate::methods`] ([`Method::module`]).
const BUILT_IN: [Method; 6] = [
    Method::Full,
    Method::Hybrid,
    Method::Image,
    Method::Simplify,
    Method::Lod,
    Method::Ulod,
];

/// A method name nobody registered.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method {name:?}; known: {known}")]
pub struct UnknownMethod {
    /// The name asked for.
    pub name: String,
    /// The known names, comma-separated.
    pub known: String,
}

impl Method {
    /// Every method: the built-in ones, then the registered modules, in
    /// the order `--help` lists them.
    pub fn all() -> impl Iterator<Item = Method> {
        BUILT_IN
            .into_iter()
            .chain(METHODS.iter().map(|m| Method::Module(m)))
    }

    /// The module that renders it: its names, its properties and how its
    /// state is made.
    pub fn module(self) -> &'static MethodModule {
        use crate::methods;
        match self {
            Method::Full => &methods::full::METHOD,
            Method::Hybrid => &methods::hybrid::METHOD,
            Method::Image => &methods::image::METHOD,
            Method::Simplify => &methods::simplify::METHOD,
            Method::Lod => &methods::lod::METHOD,
            Method::Ulod => &methods::ulod::METHOD,
            Method::Module(m) => m,
        }
    }

    /// Its one name: on the command line, in experiment designs, in
    /// reports, `--stats` and every frame's provenance.
    pub fn name(self) -> &'static str {
        self.module().name
    }

    /// Other names the command line and designs accept for it.
    pub fn aliases(self) -> &'static [&'static str] {
        self.module().aliases
    }

    /// One line of help.
    pub fn help(self) -> &'static str {
        self.module().help
    }

    /// The method called `name` (its key or an alias, exactly).
    pub fn from_name(name: &str) -> Result<Method, UnknownMethod> {
        Method::all()
            .find(|m| m.name() == name || m.aliases().contains(&name))
            .ok_or_else(|| UnknownMethod {
                name: name.to_string(),
                known: Method::all()
                    .map(Method::name)
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The method that will run for `scene` when `self` is asked for: the
    /// methods that follow the gaze (hybrid, image-based, model-based, and
    /// modules that say so) need the scene to sample `Foveated`;
    /// without it the scene is rendered at full resolution, on every
    /// backend. `Ulod` follows attention, not the gaze, and runs whatever
    /// the scene lists.
    pub fn for_scene(self, scene: &Scene) -> Method {
        if self.follows_gaze() && !scene.sampling.is_foveated() {
            Method::Full
        } else {
            self
        }
    }

    /// Whether the method renders by the gaze.
    pub fn follows_gaze(self) -> bool {
        self.module().foveated
    }

    /// Whether the method simplifies geometry and rasterises it.
    pub fn is_model_based(self) -> bool {
        matches!(self, Method::Simplify | Method::Lod)
    }
}

impl FromStr for Method {
    type Err = UnknownMethod;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Method::from_name(s)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_is_found_by_its_key_and_its_aliases_and_no_name_twice() {
        let mut seen = std::collections::BTreeSet::new();
        for m in Method::all() {
            assert_eq!(Method::from_name(m.name()), Ok(m));
            assert!(!m.help().is_empty(), "{m:?}");
            for a in m.aliases() {
                assert_eq!(Method::from_name(a), Ok(m));
            }
            for n in std::iter::once(&m.name()).chain(m.aliases()) {
                assert!(seen.insert(*n), "{n} names two methods");
            }
        }
        let e = Method::from_name("imag").expect_err("unknown");
        assert!(e.to_string().contains("known: full, hybrid, image"), "{e}");
        assert_eq!("foveated".parse::<Method>(), Ok(Method::Hybrid));
    }
}

//! Decay textures (Hao et al. 2023, section III-B): class-controlled,
//! diverse across seeds, any size, stationary.
//!
//! The paper trains a GAN (the decay effects generator). patina ships no
//! learned weights, so each class is a procedural generator built from the
//! coordinate noise of [`super::noise`], with a few style parameters drawn
//! from the seed ([`Style`]); or, in exemplar mode, any decay photo is
//! synthesized to size by the engine ([`super::exemplar`]).
//!
//! A texture has four channels: sRGB colour and an *onset*, the degree of
//! decay at which that texel appears (see [`super::composite`]): rust
//! appears first in its deepest pits, cracks before the crazed paint
//! between them, moss at the heart of each clump, paint flakes one flake at
//! a time.

use super::composite::Transition;
use super::layer::Relief;
use crate::image::noise::{mix3, ramp, segment_hash, smoothstep, Layer, Span, VoronoiEdge};
use crate::image::Image;
use crate::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Channels of a decay texture: sRGB colour, then the onset degree.
pub const CHANNELS: usize = 4;

/// The onset of texels that never appear (peeling's intact paint).
pub const NEVER: f32 = 1.0;

/// The kind of decay.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DecayClass {
    /// Corrosion: swirled layers of dark brown to orange-ochre oxide, pitted and granular.
    Rust,
    /// Paint flaking off in chipped patches, showing primer on a painted object or the body under the surface on a grey one.
    Peeling,
    /// Crazed paint or plaster: a network of cracks (large cells split into smaller ones).
    Cracked,
    /// Moss: cushions of tiny bright tips over dark gaps, in clumps.
    Mossy,
}

impl DecayClass {
    /// Every class, in CLI order.
    pub const ALL: [DecayClass; 4] = [DecayClass::Rust, DecayClass::Peeling, DecayClass::Cracked, DecayClass::Mossy];

    /// How much of the photo's specular highlight the decayed material
    /// keeps ([`super::shading::with_gloss`]): oxide and moss are matte;
    /// peeling and crazed paint keep part of the paint's sheen.
    pub fn gloss(self) -> f32 {
        match self {
            DecayClass::Rust | DecayClass::Mossy => 0.0,
            DecayClass::Peeling => 0.3,
            DecayClass::Cracked => 0.5,
        }
    }

    /// The stained zone around the class's decay ([`Transition`]), in
    /// pixels of the texture (whose features are sized in pixels too):
    /// rust bleeds a translucent orange-brown glaze a few pixels into the
    /// paint; a flake casts a thin shadow down-right from its lifted lip;
    /// moss leaves a damp, darker olive rim; cracks gather a little grime.
    pub fn transition(self) -> Transition {
        match self {
            DecayClass::Rust => {
                Transition { width: 9.0, tint: [0.85, 0.45, 0.16], strength: 1.0, offset: [0.0, 0.0], drip: 110.0, drip_gain: 1.0 }
            }
            DecayClass::Peeling => {
                Transition { width: 1.2, tint: [0.45, 0.43, 0.4], strength: 0.8, offset: [1.5, 1.5], drip: 0.0, drip_gain: 1.0 }
            }
            DecayClass::Cracked => {
                Transition { width: 1.0, tint: [0.62, 0.6, 0.57], strength: 0.6, offset: [0.0, 0.0], drip: 0.0, drip_gain: 1.0 }
            }
            DecayClass::Mossy => {
                Transition { width: 6.0, tint: [0.5, 0.56, 0.32], strength: 0.8, offset: [0.0, 0.0], drip: 0.0, drip_gain: 1.0 }
            }
        }
    }

    /// Opacity of a texel in its first frame ([`super::composite::maturity`]):
    /// young moss is sparse and young rust a thin film, so they start
    /// part-way and thicken (rust from 0.75: at 0.6 over white stone it
    /// read as a pink wash); a flake is gone or not, and a crack is open
    /// or not, so they appear whole.
    pub fn young_opacity(self) -> f32 {
        match self {
            DecayClass::Rust => 0.75,
            DecayClass::Mossy => 0.6,
            DecayClass::Peeling | DecayClass::Cracked => 1.0,
        }
    }

    /// The decay layer's relief ([`super::layer`]), in pixels of the
    /// texture: a paint flake leaves a hole of the paint's thickness (a
    /// lit lip on one side, a wall and a thin cast shadow on the other), a
    /// crack is a narrow groove, rust scale stands a little proud, a moss
    /// cushion is thick and shades its own far side. On bare stone
    /// (`substrate`), what flakes is a skin or limewash thinner than a coat
    /// of paint: a soft 3 px lip there stood up as embossed bumps round the
    /// flakes ("a Photoshop emboss against the sharp photo"), and a 1.2 px
    /// one read as flat stains.
    pub fn relief(self, substrate: Substrate) -> Relief {
        match self {
            DecayClass::Peeling if substrate.is_stony() => Relief { height: -2.0, softness: 0.5, strength: 1.1, shadow: 0.65 },
            DecayClass::Peeling => Relief { height: -3.0, softness: 0.7, strength: 1.3, shadow: 0.75 },
            DecayClass::Cracked if substrate.is_stony() => Relief { height: -1.2, softness: 0.4, strength: 0.5, shadow: 0.5 },
            DecayClass::Cracked => Relief { height: -1.6, softness: 0.6, strength: 1.0, shadow: 0.55 },
            DecayClass::Rust => Relief { height: 0.8, softness: 1.2, strength: 0.5, shadow: 0.25 },
            DecayClass::Mossy => Relief { height: 2.0, softness: 1.5, strength: 0.6, shadow: 0.35 },
        }
    }

    /// The least blur (Gaussian sigma, pixels) a procedural texture's
    /// colour takes before compositing: peeling's zones (bare metal,
    /// older coat, rusted patches) follow its chips' cell borders, drawn
    /// texel by texel, and their colour steps showed as stair-stepped
    /// edges at 1:1; the others draw their edges anti-aliased.
    pub fn edge_softness(self) -> f32 {
        match self {
            DecayClass::Peeling => 0.5,
            DecayClass::Rust | DecayClass::Mossy | DecayClass::Cracked => 0.0,
        }
    }

    /// The power of the photo's fine relief ([`super::shading::relief`]:
    /// carved letters, grain, a statue's curls) that lights the decayed
    /// layer: rust is a film and peeling bares the surface itself, so
    /// they show all of it; a moss cushion is millimetres thick and hides
    /// most of it (at 1, carved letters printed sharply through the moss
    /// and a reviewer read it as a see-through overlay). Bare stone that
    /// spalls loses the skin the carving was cut into, so a spall keeps a
    /// third of it (reviewers: "the carving stays crisp inside the
    /// spalls"). The form, at the shading window's scale, shows through
    /// every class.
    pub fn relief_through(self, substrate: Substrate) -> f32 {
        match self {
            DecayClass::Mossy => 0.25,
            DecayClass::Peeling if substrate == Substrate::Stone => 0.35,
            DecayClass::Rust | DecayClass::Peeling | DecayClass::Cracked => 1.0,
        }
    }

    /// How thick the decay layer is, in pixels: detail of the form finer
    /// than this does not light it ([`super::shading::under_a_layer`]). A
    /// moss cushion hides carving a few pixels wide; rust, a flake's floor
    /// and a crack lie on the surface itself. A spall on bare stone is the
    /// surface gone to below the carving: its floor takes only the form
    /// broader than 4 px (with [`DecayClass::relief_through`]).
    pub fn thickness(self, substrate: Substrate) -> f32 {
        match self {
            DecayClass::Mossy => 5.0,
            DecayClass::Peeling if substrate == Substrate::Stone => 4.0,
            DecayClass::Rust | DecayClass::Peeling | DecayClass::Cracked => 0.0,
        }
    }

    /// How much earlier a texel appears in the photo's deepest
    /// recesses (its onset is scaled by (1 - pull x cavity)^2, so a deep
    /// groove fills as soon as the degree's faint front reaches it) ([`super::cavities`]: grooves, carved letters, the gaps
    /// between a statue's curls, seams): moss and rust collect where water
    /// and dirt stand, so they fill a carved letter before the face around
    /// it, and moss grows in a recess between its clumps too, where the
    /// face stays bare (its texels there never appear otherwise); a flake
    /// or a crack has no such preference.
    pub fn cavity_pull(self) -> f32 {
        match self {
            DecayClass::Mossy => 0.85,
            DecayClass::Rust => 0.6,
            DecayClass::Peeling | DecayClass::Cracked => 0.0,
        }
    }

    /// Share of the texture's large-scale lightness variation (over
    /// [`super::FLATTEN_SCALE`]) that compositing removes: a layer of
    /// rust grown on an object shows the object's form through its own
    /// light and dark, while a procedural texture's swirls of dark crust
    /// and light oxide, tens of pixels across, hid a statue's nose and
    /// eyes under a cloud pattern. The texture's fine grain is kept.
    pub fn flatten(self) -> f32 {
        match self {
            DecayClass::Rust => 0.6,
            DecayClass::Mossy => 0.3,
            DecayClass::Peeling | DecayClass::Cracked => 0.0,
        }
    }

    /// Whether the texture's colour is a darkening of the photo's own
    /// rather than a material of its own: a crack is a shadowed gap in
    /// the object's paint or stone, so it takes the object's hue (dark
    /// red-brown in orange paint, dark grey in white stone). A fixed gap
    /// colour read as ink lines drawn on the photo.
    pub fn photo_relative(self) -> bool {
        self == DecayClass::Cracked
    }

    /// Whether the class's decay on `substrate` is a stain in the
    /// object's own surface rather than a layer on it: iron oxide on
    /// stone or plaster soaks in (a glaze over the stone's grain and
    /// carving, see [`super::composite::stained_photo`]); on metal it
    /// grows a crust. Crusted rust on a gravestone read as "one even,
    /// saturated darkness that erases the stone texture", and on a white
    /// statue as red powder hiding the face.
    pub fn stains(self, substrate: Substrate) -> bool {
        self == DecayClass::Rust && substrate.is_stony()
    }

    /// The class's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DecayClass::Rust => "rust",
            DecayClass::Peeling => "peeling",
            DecayClass::Cracked => "cracked",
            DecayClass::Mossy => "mossy",
        }
    }

    /// How far compositing first moves the texture's colours to the
    /// photo's (Reinhard et al. 2001), from 0 (not at all) to 1, given the
    /// object's mean Lab chroma `chroma`. The paper transfers for peeling
    /// and cracked, the decay of the object's own paint. In patina neither
    /// shows the texture's paint. Peeling shows the substrate under the
    /// paint: on a painted object (chroma 25 and up) that is the texture's
    /// primed metal, untouched; on an unpainted grey one (stone, plaster:
    /// chroma 10 and under) there is no paint, and what comes off is a
    /// surface scale, showing the object's own material beneath, so the
    /// texture is moved fully to the object's colours. Cracked shows only
    /// its cracks, dark gaps that the transfer turned into saturated lines
    /// (dark red on an orange hydrant, navy on white stone), so it gets none.
    pub fn colour_transfer(self, chroma: f32) -> f32 {
        match self {
            DecayClass::Peeling => 1.0 - smoothstep(10.0, 25.0, chroma),
            DecayClass::Cracked | DecayClass::Rust | DecayClass::Mossy => 0.0,
        }
    }
}

impl std::str::FromStr for DecayClass {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        DecayClass::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| Error::invalid(format!("unknown decay class '{s}' (expected rust, peeling, cracked or mossy)")))
    }
}

/// Style parameters drawn from the seed, so seeds differ in look and not
/// only in layout.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Style {
    /// Feature scale multiplier, 0.75 to 1.35.
    pub scale: f32,
    /// A palette / character choice in [0, 1) (which paint, which
    /// substrate, how yellow the moss).
    pub variant: f32,
    /// Direction of elongation (peeling follows the grain), radians.
    pub angle: f32,
    /// Elongation, 1 to 3.
    pub stretch: f32,
}

impl Style {
    /// The style of texture `seed`.
    pub fn draw(seed: u64) -> Self {
        let u = |i: u64| Layer::new(seed, 1000 + i).white(0, 0);
        Style { scale: 0.75 + 0.6 * u(0), variant: u(1), angle: (u(2) - 0.5) * 0.5, stretch: 1.0 + 2.0 * u(3) }
    }
}

/// Generate the `width` x `height` window at (`x0`, `y0`) of the infinite
/// texture of `class` and `seed`. Every texel depends only on its absolute
/// position, so windows of one texture tile it exactly.
pub fn generate(class: DecayClass, seed: u64, x0: i64, y0: i64, width: usize, height: usize, substrate: Substrate) -> Result<Image> {
    render(class, Generator { seed, style: Style::draw(seed), period: None, substrate, light: DEFAULT_LIGHT }, (x0, y0), (width, height))
}

/// Generate a `width` x `height` texture of `class` and `seed` that tiles
/// seamlessly: its left edge continues its right and its top its bottom
/// (every noise lattice wraps around, see [`Layer::tiling`]). The same
/// material as [`generate`]'s (on paint), not the same pixels.
pub fn generate_tiling(class: DecayClass, seed: u64, width: usize, height: usize, substrate: Substrate) -> Result<Image> {
    generate_tiling_lit(class, seed, width, height, substrate, DEFAULT_LIGHT)
}

/// [`generate_tiling`] with the texture's own relief (a moss cushion's
/// dome) lit from `light`, a unit vector in the image plane towards the
/// light (y down; [`super::layer::light_direction`] of the photo), so the
/// cushions take the photo's light instead of a fixed one.
pub fn generate_tiling_lit(
    class: DecayClass,
    seed: u64,
    width: usize,
    height: usize,
    substrate: Substrate,
    light: [f32; 2],
) -> Result<Image> {
    let gen = Generator { seed, style: Style::draw(seed), period: Some((width as f32, height as f32)), substrate, light };
    render(class, gen, (0, 0), (width, height))
}

/// The light a texture is drawn under when the photo's is not known:
/// from above and to the left (as [`super::layer::light_direction`]'s default).
pub const DEFAULT_LIGHT: [f32; 2] = [-0.45, -0.89];

/// The texels of `gen`'s `class` over the window at `(x0, y0)`.
fn render(class: DecayClass, gen: Generator, (x0, y0): (i64, i64), (width, height): (usize, usize)) -> Result<Image> {
    crate::image::budget::check_working_set("decay texture", width, height, CHANNELS)?;
    if width == 0 || height == 0 {
        return Err(Error::invalid(format!("decay texture size {width}x{height} is empty")));
    }
    let texel: fn(&Generator, f32, f32) -> [f32; 4] = match class {
        DecayClass::Rust => rust,
        DecayClass::Peeling => peeling,
        DecayClass::Cracked => cracked,
        DecayClass::Mossy => mossy,
    };
    let mut img = Image::new(width, height, CHANNELS);
    img.data_mut().par_chunks_mut(width * CHANNELS).enumerate().for_each(|(y, row)| {
        for (x, px) in row.chunks_exact_mut(CHANNELS).enumerate() {
            let v = texel(&gen, (x0 + x as i64) as f32, (y0 + y as i64) as f32);
            for (o, v) in px.iter_mut().zip(v) {
                *o = v.clamp(0.0, 1.0);
            }
        }
    });
    Ok(img)
}

/// A class's texel function and what it reads: the seed, its style and the period.
struct Generator {
    seed: u64,
    style: Style,
    /// The texture repeats every (width, height) pixels; `None`: never.
    period: Option<(f32, f32)>,
    /// What the decay grows on.
    substrate: Substrate,
    /// Towards the light in the image plane (unit, y down).
    light: [f32; 2],
}

/// What a decay texture is made for: some decay takes a different form
/// on bare stone or plaster than on paint.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Substrate {
    /// Painted or coloured objects (and any object when unknown): cracks
    /// craze the paint into a network of cells.
    #[default]
    Paint,
    /// Unpainted grey stone or plaster (mean Lab chroma under
    /// [`STONE_CHROMA`]): cracks are a few long, wider fractures that end,
    /// not crazing (a blind reviewer: "crazing is wrong for slate"); a
    /// weathered skin spalls off, baring rough, fresher stone.
    Stone,
    /// A grey object coated white (limewash, or paint on a plaster cast):
    /// it cracks as [`Substrate::Stone`] does, and its coat peels as
    /// paint does, in chips, baring a darker, warmer body.
    Coated,
}

/// Mean Lab chroma under which an object counts as bare stone ([`Substrate::Stone`]).
pub const STONE_CHROMA: f32 = 10.0;

impl Substrate {
    /// The substrate of an object whose mean Lab chroma is `chroma`:
    /// under [`STONE_CHROMA`] it is stone, or [`Substrate::Coated`] when
    /// `white` (see [`super::is_coated_white`]).
    pub fn of(chroma: f32, white: bool) -> Self {
        match (chroma < STONE_CHROMA, white) {
            (false, _) => Substrate::Paint,
            (true, false) => Substrate::Stone,
            (true, true) => Substrate::Coated,
        }
    }

    /// Whether the object is unpainted stone or plaster, coated or not.
    pub fn is_stony(self) -> bool {
        self != Substrate::Paint
    }
}

impl Generator {
    fn layer(&self, i: u64) -> Layer {
        let layer = Layer::new(self.seed, i);
        self.period.map_or(layer, |(w, h)| layer.tiling(w, h))
    }

    /// Layer `i` read along the grain at (x, y): the layer and where the
    /// point falls in the grain's frame, rotated by the style angle and
    /// squeezed along it by the stretch (times `widen`), so features
    /// elongate along the grain. A tiling texture's frame is squeezed
    /// along x only, and its layer repeats at the squeezed width (a
    /// rotated frame cannot repeat on the axes).
    fn along_grain(&self, i: u64, x: f32, y: f32, widen: f32) -> (Layer, f32, f32) {
        let layer = Layer::new(self.seed, i);
        match self.period {
            None => {
                let (s, c) = self.style.angle.sin_cos();
                let (u, v) = (c * x + s * y, -s * x + c * y);
                (layer, u / self.style.stretch * widen, v)
            }
            Some((w, h)) => {
                let k = widen / self.style.stretch;
                (layer.tiling(w * k, h), x * k, y)
            }
        }
    }
}

/// Rust: domain-warped layers (the swirls of corroded_rust_swirls) mapped
/// through an oxide palette (no contour lines: reviewers read them as banding), zones of
/// yellow-ochre and black oxide, a dark crust of scale plates (cellular,
/// with dark gaps), bright granular blooms and grain; onset lowest in the
/// deepest corrosion, ragged at the scale of blisters.
fn rust(g: &Generator, x: f32, y: f32) -> [f32; 4] {
    let s = g.style.scale;
    let field = g.layer(0).warped(x, y, 80.0 * s, 6, 55.0 * s);
    let depth = (0.42 + 0.85 * field).clamp(0.0, 1.0);
    let grain = g.layer(2).white(x as i32, y as i32) - 0.5;
    let fine = g.layer(3).fbm(x, y, 3.0, 3, 0.6);
    let crust = smoothstep(0.05, 0.4, g.layer(4).fbm(x, y, 14.0 * s, 3, 0.55) - 0.6 * (depth - 0.5));
    let bloom = smoothstep(0.35, 0.55, g.layer(6).fbm(x, y, 6.0 * s, 3, 0.6)) * smoothstep(0.3, 0.6, depth);
    // Palettes from the sample photos: dark scale, red-brown, orange (a
    // pale ochre top stop made gold streaks where the field saturates).
    let red = if g.style.variant < 0.5 { [0.36, 0.12, 0.05] } else { [0.30, 0.13, 0.07] };
    let stops = [(0.0, [0.09, 0.05, 0.03]), (0.3, red), (0.58, [0.60, 0.25, 0.08]), (0.85, [0.70, 0.38, 0.13])];
    let mut c = ramp(&stops, depth + 0.1 * fine);
    // Oxides of more than one colour, in zones tens of pixels across:
    // yellow-ochre hydrated oxide where it is thin and wet, black-grey
    // magnetite in the deep corrosion.
    let ochre = smoothstep(0.25, 0.6, g.layer(8).fbm(x, y, 35.0 * s, 3, 0.55)) * smoothstep(0.35, 0.7, depth);
    let black = smoothstep(0.3, 0.6, g.layer(9).fbm(x, y, 25.0 * s, 3, 0.55)) * smoothstep(0.55, 0.25, depth);
    c = mix3(c, [0.66, 0.46, 0.18], 0.55 * ochre);
    c = mix3(c, [0.13, 0.11, 0.10], 0.6 * black);
    c = mix3(c, [0.22, 0.095, 0.05], 0.7 * crust);
    c = mix3(c, [0.82, 0.42, 0.12], 0.7 * bloom * (1.0 - crust));
    // The crust is scale: plates a few pixels across, split by dark gaps
    // and lit on their upper-left rims.
    let plate = g.layer(10).worley(x, y, 5.0 * s);
    let gap = smoothstep(0.0, 1.2, plate.border());
    let rim = smoothstep(2.5, 0.5, plate.f1) * 0.5;
    let scale_shade = 0.7 + 0.3 * gap + 0.12 * rim * (plate.id - 0.3);
    let shade = (1.0 + 0.08 * grain + 0.12 * fine) * (1.0 + crust * (scale_shade - 1.0));
    c = c.map(|v| v * shade);
    let patches = g.layer(5).fbm(x, y, 70.0 * s, 4, 0.5);
    // The front is ragged at the scale of blisters (6 px), granular but
    // not a pixel dither: pixel-scale onsets (3 px fBm at 0.12) switched
    // single texels on and off along every front, which reviewers read as
    // digital dithering.
    let ragged = g.layer(7).fbm(x, y, 6.0, 3, 0.5);
    let onset = 0.42 - 0.55 * patches + 0.04 * fine + 0.12 * ragged - 0.1 * crust;
    [c[0], c[1], c[2], onset.clamp(0.02, 0.95)]
}

/// Peeling paint: the paint comes off in patches whose borders are made
/// of whole chips (cells of 3-8 px), so an edge is jagged at the chip
/// scale as on the lockers and shutters of ../shared/data, and a patch
/// widens chip by chip as the degree rises: each chip's onset is the
/// slow patch field at that point plus its own random offset, so the
/// border advances by chips breaking off, not by a smooth front. Where the
/// paint is gone the texture shows an older coat at first (its own chips
/// come off in turn) and then the substrate: here bare primed metal,
/// a dark grey primer mottled with rust stains, rustier where it was bared
/// first (the lowest onsets), and pitted grain; on
/// a grey object coated white ([`Substrate::Coated`]) compositing moves it
/// to the object's own colour, darker and warmer (see
/// [`DecayClass::colour_transfer`]); on bare stone ([`Substrate::Stone`])
/// the bared texel is a spalled fracture surface instead ([`spalled`]). The step at each border,
/// its lit lip and cast shadow, comes from the layer relief
/// ([`super::layer`]), not from the texture. The paint between patches
/// never appears: it is the photo's own.
fn peeling(g: &Generator, x: f32, y: f32) -> [f32; 4] {
    let s = g.style.scale;
    // Mildly elongated along the grain; a strong stretch read as streaks.
    let (layer, u, v) = g.along_grain(0, x, y, 0.5 + 0.5 * g.style.stretch);
    let patch = layer.warped(u, v, 70.0 * s, 5, 30.0 * s);
    // Two layers of cells offset each chip's onset (their ids weigh 0.22 and 0.1).
    let cells = |x: f32, y: f32| (g.layer(1).worley(x, y, 8.0 * s), g.layer(6).worley(x, y, 3.5));
    let (big, small) = cells(x, y);
    let ragged = g.layer(7).fbm(x, y, 2.0, 2, 0.5);
    let onset = 0.45 - 1.1 * patch + 0.22 * (big.id - 0.5) + 0.1 * (small.id - 0.5) + 0.04 * ragged;
    let grain = g.layer(2).white(x as i32, y as i32) - 0.5;
    if onset >= 0.95 {
        // Paint that stays: never shown on a photo (the photo's own paint
        // is), drawn as a cream coat so the texture alone shows its flakes.
        let tone = 0.93 + 0.05 * g.layer(9).fbm(x, y, 40.0 * s, 3, 0.5) + 0.03 * grain;
        return [0.80 * tone, 0.77 * tone, 0.70 * tone, NEVER];
    }
    if g.substrate == Substrate::Stone {
        let c = spalled(g, x, y, onset, grain);
        return [c[0], c[1], c[2], onset.clamp(0.02, 0.95)];
    }
    let mottle = g.layer(3).fbm(x, y, 16.0, 4, 0.6);
    let stain = smoothstep(0.1, 0.45, g.layer(4).fbm(x, y, 22.0 * s, 4, 0.55));
    let pits = g.layer(5).worley(x, y, 11.0);
    let pit = smoothstep(2.2, 0.8, pits.f1) * (pits.id < 0.06) as u8 as f32;
    let primer = mix3([0.27, 0.25, 0.23], [0.38, 0.35, 0.31], 0.5 + 0.7 * mottle);
    // Metal bared first has rusted longest: the oldest chips bloom orange-brown.
    let rusted = (0.8 * stain + 0.6 * smoothstep(0.35, 0.05, onset)).min(1.0);
    let mut c = mix3(primer, [0.42, 0.22, 0.10], 0.8 * rusted);
    c = mix3(c, [0.30, 0.17, 0.10], 0.7 * pit);
    // An older coat under the paint: the chips bared last (the highest
    // onsets, at a patch's fringe) still carry it, chipped in its own
    // cells; the metal shows where the patch opened first.
    let chips = g.layer(11);
    let coated = |onset: f32, id: f32| (onset + 0.16 * (id - 0.5) > UNDERCOAT_FROM) as u8 as f32;
    let chip = chips.worley(x, y, 5.0 * s);
    // The coat's edge follows the chips' and the onset cells' borders; it
    // is anti-aliased by 4 samples a quarter pixel apart where any of them
    // passes within a pixel (only the chips' were: the others stair-stepped
    // at 1:1, "like an enlarged low-resolution mask").
    let coat_share = if chip.border().min(big.border()).min(small.border()) < 1.0 {
        0.25 * [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)]
            .iter()
            .map(|(dx, dy)| {
                let (bx, by) = (x + dx, y + dy);
                let (b, m) = cells(bx, by);
                let onset = onset + 0.22 * (b.id - big.id) + 0.1 * (m.id - small.id);
                coated(onset, chips.worley(bx, by, 5.0 * s).id)
            })
            .sum::<f32>()
    } else {
        coated(onset, chip.id)
    };
    if coat_share > 0.0 {
        let coat = UNDERCOATS[((g.style.variant * UNDERCOATS.len() as f32) as usize).min(UNDERCOATS.len() - 1)];
        let wear = 0.9 + 0.1 * mottle;
        c = mix3(c, mix3(coat.map(|v| v * wear), c, 0.25 * stain), coat_share);
    }
    let fine = g.layer(8).fbm(x, y, 1.5, 2, 0.5);
    c = c.map(|v| v * (1.0 + 0.07 * grain + 0.08 * fine));
    [c[0], c[1], c[2], onset.clamp(0.02, 0.95)]
}

/// What [`peeling`] bares on unpainted stone or plaster, where a weathered
/// skin spalls: a rough fracture surface of grains 1-3 px across, each
/// lit or shaded, with small pits and a faint mottle; the patch's heart,
/// bared first, lies a sheet deeper and is rougher. Neutral grey:
/// compositing moves it to the object's own colour. The primed metal
/// and rust stains of painted objects, moved to a grey stone's colours,
/// read as brown stains on a gravestone (blind review, stop 60).
fn spalled(g: &Generator, x: f32, y: f32, onset: f32, grain: f32) -> [f32; 3] {
    let s = g.style.scale;
    let deep = smoothstep(0.35, 0.15, onset);
    let grains = g.layer(12).worley(x, y, 2.5);
    let lit = smoothstep(1.4, 0.2, grains.f1) * (grains.id - 0.5);
    let pits = g.layer(5).worley(x, y, 9.0);
    let pit = smoothstep(1.8, 0.5, pits.f1) * (pits.id < 0.12) as u8 as f32;
    let mottle = g.layer(3).fbm(x, y, 20.0 * s, 3, 0.55);
    let tone = 0.5 * (1.0 - 0.06 * deep) + 0.04 * mottle + (0.16 + 0.08 * deep) * lit + 0.06 * grain - 0.15 * pit;
    [1.02 * tone, tone, 0.97 * tone]
}

/// Onset above which [`peeling`]'s bared texel still shows the older coat.
const UNDERCOAT_FROM: f32 = 0.3;

/// The older coats under [`peeling`]'s paint (sRGB), one per style
/// variant: red-oxide primer, a mid-grey primer (at 0.56 it matched a
/// sidewalk, and where it reached a hydrant's outline the outline
/// vanished), an old cream coat.
const UNDERCOATS: [[f32; 3]; 3] = [[0.50, 0.24, 0.16], [0.46, 0.46, 0.45], [0.78, 0.75, 0.66]];

/// Cracked paint or plaster: a warped cellular crack network (exact
/// Voronoi edges), large cells split by a finer network in places, crack
/// width varying along the crack. Only the cracks
/// appear on a photo, their cores first and their edges later, so they
/// widen as the degree rises; the crazed surface between them is the
/// photo's own (it never appears: replacing it flattened the object's
/// relief into washed cells). Stone and coated stone fracture instead
/// ([`fractured`]).
fn cracked(g: &Generator, x: f32, y: f32) -> [f32; 4] {
    if g.substrate.is_stony() {
        return fractured(g, x, y);
    }
    let s = g.style.scale;
    let wx = x + 7.0 * s * g.layer(0).fbm(x, y, 30.0 * s, 3, 0.5);
    let wy = y + 7.0 * s * g.layer(1).fbm(x + 91.0, y, 30.0 * s, 3, 0.5);
    let (big_edge, small_edge) = (g.layer(2).voronoi_edge(wx, wy, 40.0 * s), g.layer(3).voronoi_edge(wx, wy, 17.0 * s));
    let (big, small) = (big_edge.distance, small_edge.distance);
    let split = smoothstep(-0.1, 0.2, g.layer(4).fbm(x, y, 90.0 * s, 3, 0.5));
    // Main cracks gape up to about 2 px; finer ones are lighter, but no
    // thinner than a pixel (thinner ones broke into dotted chains).
    let width = 0.8 + 0.5 * g.layer(5).fbm(x, y, 25.0, 2, 0.5);
    let big_crack = 1.0 - smoothstep(width * 0.5, width + 0.7, big);
    let small_crack = split * (1.0 - smoothstep(0.3, 0.9 + 0.3 * width, small));
    let crack = big_crack.max(0.85 * small_crack);
    let c = crack_colour(g, x, y, crack);
    // Main cracks open before the finer network.
    let segment = if big_crack >= 0.85 * small_crack { big_edge.segment() } else { 0.15 + small_edge.segment() };
    [c[0], c[1], c[2], crack_onset(g, (x, y), s, segment, crack, 0.0)]
}

/// The onset of a crack texel of coverage `crack` on a border segment
/// with hash `segment`, at style scale `s`: a crack opens a whole border
/// segment at a time (the segment's own onset, earlier where a slow field
/// spreads the cracking first), then widens: opening texel by texel along
/// the degree front drew bramble-like spurs; `delay` is added. [`NEVER`]
/// off the cracks.
fn crack_onset(g: &Generator, (x, y): (f32, f32), s: f32, segment: f32, crack: f32, delay: f32) -> f32 {
    let spread = g.layer(8).fbm(x, y, 100.0 * s, 3, 0.5);
    let onset = 0.15 - 0.45 * spread + 0.3 * (segment - 0.5) + 0.15 * (1.0 - crack) + delay;
    if crack > 0.05 {
        onset.clamp(0.02, 0.95)
    } else {
        NEVER
    }
}

/// A crack's colour at coverage `crack`: a dark grey gap, darkest at its
/// core, fading into the surface at its anti-aliased edges; its walls'
/// light and shade come from the layer relief. On a photo it darkens the
/// photo's own colour (see [`DecayClass::photo_relative`]).
fn crack_colour(g: &Generator, x: f32, y: f32, crack: f32) -> [f32; 3] {
    let grain = g.layer(6).white(x as i32, y as i32) - 0.5;
    let gap = [0.42, 0.40, 0.37].map(|v| v * (0.8 + 0.6 * (1.0 - crack) + 0.1 * grain));
    mix3(CRACKED_SURFACE, gap, smoothstep(0.05, 0.6, crack))
}

/// Stone fractures (a blind reviewer: "crazing is wrong for slate", and
/// later "even-width ink lines", "blurry 6 px strokes with dark wedges at
/// junctions"): a few long cracks along some of the borders of cells 2.2
/// times crazing's, jagged at a few pixels as a fracture follows the
/// grain. A fracture runs along [`STONE_FRACTURES`] of the border
/// segments ([`Layer::voronoi_span`] tells where a point lies along its
/// segment and which segments meet at its ends); where none of the
/// segments at a junction goes on, the crack ends, tapering to a hairline
/// over up to [`TIP_TAPER`] pixels. Its width wanders along it between a
/// hairline and 4 px (log-normal fBm, median 1.7 px), and its profile is a line's
/// exact coverage of each pixel, so it is as sharp as the photo (the
/// smoothstep profile of crazing read as a felt-tip stroke). The tips
/// open last, so a crack lengthens over the frames.
fn fractured(g: &Generator, x: f32, y: f32) -> [f32; 4] {
    let s = g.style.scale * FRACTURE_SCALE;
    let (edge, span) = fracture_cells(g, x, y);
    if !fractures(edge.id, edge.across) {
        return [CRACKED_SURFACE[0], CRACKED_SURFACE[1], CRACKED_SURFACE[2], NEVER];
    }
    let length = span.before + span.after;
    let taper_length = (0.45 * length).min(TIP_TAPER * g.style.scale);
    let tip = |end: f32, along: f32| {
        let goes_on = fractures(edge.id, end) || fractures(edge.across, end);
        if goes_on {
            1.0
        } else {
            smoothstep(0.0, taper_length, along).powf(0.7)
        }
    };
    let taper = tip(span.ends[0], span.before).min(tip(span.ends[1], span.after));
    let width = (1.7 * (2.6 * g.layer(5).fbm(x, y, 35.0, 2, 0.5)).exp()).min(4.0) * taper;
    // A line of `width` covers a pixel at distance d from its axis by about
    // (width / 2 + 1/2 - d), clamped to [0, 1], and by no more than its
    // width when it is thinner than the pixel.
    let line = (0.5 * width + 0.5 - edge.distance).clamp(0.0, 1.0).min(width);
    // Where it gapes, the edge has broken off in chips: small cells along
    // the crack, shallower than the gap, up to 3 px from its lip.
    let chip_cell = g.layer(11).worley(x, y, 5.0);
    let chipped = chip_cell.id < CHIPPED * smoothstep(1.5, 3.0, width);
    let reach = 0.5 * width + 3.0 * chip_cell.id / CHIPPED;
    let chip = if chipped { CHIP_DEPTH * (reach + 0.5 - edge.distance).clamp(0.0, 1.0) } else { 0.0 };
    let crack = line.max(chip);
    let c = crack_colour(g, x, y, crack);
    // The tips open last.
    let onset = crack_onset(g, (x, y), s, segment_hash(edge.id, edge.across), crack, 0.25 * (1.0 - taper));
    [c[0], c[1], c[2], onset]
}

/// How much larger [`fractured`]'s cells are than crazing's.
const FRACTURE_SCALE: f32 = 2.2;

/// The border of [`fractured`]'s cells nearest (x, y), and where the
/// point lies along it: cells warped more than crazing's, and jagged at a
/// few pixels as a fracture follows the grain.
fn fracture_cells(g: &Generator, x: f32, y: f32) -> (VoronoiEdge, Span) {
    let s = g.style.scale * FRACTURE_SCALE;
    let wx = x + 10.0 * s * g.layer(0).fbm(x, y, 30.0 * s, 3, 0.5) + 2.0 * g.layer(9).fbm(x, y, 6.0, 2, 0.6);
    let wy = y + 10.0 * s * g.layer(1).fbm(x + 91.0, y, 30.0 * s, 3, 0.5) + 2.0 * g.layer(10).fbm(x, y, 6.0, 2, 0.6);
    g.layer(2).voronoi_span(wx, wy, 40.0 * s)
}

/// Share of the cell borders along which a stone fractures ([`fractured`]).
const STONE_FRACTURES: f32 = 0.55;

/// Whether the border between the cells with hashes `a` and `b` is one
/// of the [`STONE_FRACTURES`] that fracture.
fn fractures(a: f32, b: f32) -> bool {
    segment_hash(a, b) < STONE_FRACTURES
}

/// Share of the small cells along a gaping fracture ([`fractured`]) that chip off its lip.
const CHIPPED: f32 = 0.35;
/// A chip's coverage: shallower than the crack's gap.
const CHIP_DEPTH: f32 = 0.45;

/// Longest stretch (pixels, at style scale 1) over which a stone
/// fracture narrows to its tip ([`fractured`]).
const TIP_TAPER: f32 = 30.0;

/// The crazed surface of [`cracked`] between its cracks (sRGB): what a
/// crack's colour is measured against when it darkens a photo.
pub const CRACKED_SURFACE: [f32; 3] = [0.72, 0.69, 0.64];

/// Moss: rounded cushions (warped cells of about 22 px, each a dome lit
/// from the top left, shaded on its far side and darker in the crevices
/// between cushions) of fine bright tips (cellular noise at 2-3 px), in
/// clumps from warped fBm whose cushions flatten towards the clump's
/// edge. A clump grows outward from its heart cushion by cushion (each
/// cushion's onset carries its own offset, and its dome's top appears
/// before its rim), so its outline is lumpy, not a threshold curve.
/// Between the clumps (about 30% of the texture) the object shows through:
/// those texels never appear, except in the photo's recesses (see
/// [`DecayClass::cavity_pull`]). A continuous olive felt there, at
/// e3688fb, read as a flat layer of paint. The texture alone draws the
/// gaps as flat moss.
fn mossy(g: &Generator, x: f32, y: f32) -> [f32; 4] {
    let s = g.style.scale;
    let clump = g.layer(0).warped(x, y, 45.0 * s, 5, 20.0 * s);
    let cover = smoothstep(-0.1, 0.25, clump);
    // A cushion's dome: a rounded cap over its cell, from the cell border
    // inward, lower where the clump thins out. Cushions come in two sizes,
    // the larger where a slow field says so, so they are not one even
    // pebble size.
    let (wx, wy) = (g.layer(9).fbm(x, y, 8.0, 2, 0.5), g.layer(10).fbm(x, y, 8.0, 2, 0.5));
    let large = smoothstep(-0.15, 0.15, g.layer(11).fbm(x, y, 70.0 * s, 2, 0.5));
    let dome = |x: f32, y: f32| {
        let (x, y) = (x + 8.0 * wx, y + 8.0 * wy);
        let (layer, cell) = if large > 0.5 { (g.layer(12), 30.0 * s) } else { (g.layer(1), 14.0 * s) };
        let c = layer.worley(x, y, cell);
        let r = (c.border() / (0.5 * cell)).min(1.0);
        let cap = (1.0 - (1.0 - r) * (1.0 - r)).sqrt();
        (cap * (0.25 + 0.75 * cover) * (0.75 + 0.5 * c.id), c.id)
    };
    let (height, id) = dome(x, y);
    // Lambert on the cap under the generator's light: the whole cushion
    // shades round, not a bright crescent on its lit rim (reviewers:
    // polka dots); a slope rising away from the light faces it.
    let (hx, hy) = (2.0 * (dome(x + 1.5, y).0 - height), 2.0 * (dome(x, y + 1.5).0 - height));
    let lit = (1.0 - 0.85 * (hx * g.light[0] + hy * g.light[1])).clamp(0.7, 1.2);
    let crevice = 0.65 + 0.35 * smoothstep(0.0, 0.5, height);
    // Tips of two sizes, their size varying across the cushion.
    let (b1, b2) = (g.layer(5).worley(x, y, 2.0), g.layer(6).worley(x, y, 3.2));
    let size = 0.8 + 0.4 * g.layer(7).fbm(x, y, 10.0, 2, 0.5);
    let tip = smoothstep(1.6 * size, 0.2, b1.f1).max(0.8 * smoothstep(2.4 * size, 0.4, b2.f1));
    // Each cushion its own green, and about one in twenty gone dry, olive-tan.
    let hue = g.layer(2).fbm(x, y, 60.0 * s, 3, 0.5);
    let yellow = (0.35 * g.style.variant + 0.3 * hue + 0.5 * (id - 0.5)).clamp(0.0, 1.0);
    let dry = smoothstep(0.92, 0.95, (id * 7.31).fract());
    let dark = [0.09, 0.13, 0.04];
    let mid = mix3(mix3([0.26, 0.38, 0.08], [0.40, 0.44, 0.10], yellow), [0.38, 0.37, 0.16], dry);
    let light = mix3(mix3([0.46, 0.58, 0.16], [0.60, 0.64, 0.22], yellow), [0.56, 0.54, 0.28], dry);
    let fuzz = g.layer(8).fbm(x, y, 1.5, 2, 0.5);
    let moss = ramp(&[(0.0, dark), (0.5, mid), (1.0, light)], 0.25 + 0.4 * tip + 0.15 * fuzz + 0.2 * height);
    let c = moss.map(|v| v * lit * crevice);
    let ragged = g.layer(4).fbm(x, y, 3.0, 2, 0.5);
    let onset = 0.45 - 0.6 * clump + 0.16 * (id - 0.5) + 0.1 * (1.0 - height) + 0.06 * ragged;
    // Between the clumps only a recess grows moss (see `cavity_pull`).
    let onset = if cover > 0.0 { onset.clamp(0.02, 0.95) } else { NEVER };
    [c[0], c[1], c[2], onset]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiling texture continues across its edges: the window shifted by
    /// (-5, -3) of the same periodic texture starts with the texture's last
    /// 5 columns and 3 rows, texel for texel.
    #[test]
    fn a_tiling_texture_repeats_at_its_size() {
        let (w, h) = (97, 61);
        for class in DecayClass::ALL {
            let texture = generate_tiling(class, 3, w, h, Substrate::Stone).unwrap();
            let gen = Generator {
                seed: 3,
                style: Style::draw(3),
                period: Some((w as f32, h as f32)),
                substrate: Substrate::Stone,
                light: DEFAULT_LIGHT,
            };
            let shifted = render(class, gen, (-5, -3), (w, h)).unwrap();
            for (x, y) in [(0, 0), (4, 2), (3, 40), (50, 1), (0, 60)] {
                let (sx, sy) = ((x + w - 5) % w, (y + h - 3) % h);
                let (a, b) = (shifted.pixel(x, y), texture.pixel(sx, sy));
                for c in 0..CHANNELS {
                    assert!((a[c] - b[c]).abs() < 2e-3, "{class:?} at ({x}, {y}) channel {c}: {} vs {}", a[c], b[c]);
                }
            }
        }
    }

    /// A stone fracture ends in a hairline: on the axis of a fractured
    /// border segment, texels within 2 px of a free end (a junction where
    /// no other segment fractures) are less than half as dark as texels
    /// more than 25 px from either end. Its width wanders: 1.5 px off the
    /// axis, mid-run, the crack covers some texels and not others.
    #[test]
    fn stone_fractures_taper_to_their_tips_and_vary_in_width() {
        let g = Generator { seed: 4, style: Style::draw(4), period: None, substrate: Substrate::Stone, light: DEFAULT_LIGHT };
        let luma = crate::image::color::pixel_luminance;
        let plain = luma(&CRACKED_SURFACE);
        let (mut tips, mut middles, mut off_axis) = (Vec::new(), Vec::new(), Vec::new());
        for y in 0..600 {
            for x in 0..600 {
                let (x, y) = (x as f32, y as f32);
                let (edge, span) = fracture_cells(&g, x, y);
                if !fractures(edge.id, edge.across) {
                    continue;
                }
                let free = |end: f32| !fractures(edge.id, end) && !fractures(edge.across, end);
                let dark = 1.0 - luma(&fractured(&g, x, y)) / plain;
                let to_free_end = [(span.ends[0], span.before), (span.ends[1], span.after)]
                    .iter()
                    .filter(|(end, _)| free(*end))
                    .map(|&(_, along)| along)
                    .fold(f32::MAX, f32::min);
                if edge.distance < 0.3 && to_free_end < 2.0 {
                    tips.push(dark);
                }
                if span.before.min(span.after) > 25.0 {
                    if edge.distance < 0.3 {
                        middles.push(dark);
                    } else if (edge.distance - 1.5).abs() < 0.25 {
                        off_axis.push(dark);
                    }
                }
            }
        }
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len().max(1) as f32;
        assert!(tips.len() >= 20 && middles.len() >= 100, "{} tips, {} middles", tips.len(), middles.len());
        assert!(mean(&tips) < 0.5 * mean(&middles), "tips {} vs middles {}", mean(&tips), mean(&middles));
        let covered = off_axis.iter().filter(|&&d| d > 0.1).count() as f32 / off_axis.len() as f32;
        assert!((0.1..0.9).contains(&covered), "{covered} of {} texels 1.5 px off the axis covered", off_axis.len());
    }

    /// Moss cushions take the light they are drawn under: across a
    /// cushion lit from the left, the lightness climbs steeply out of the
    /// dark crevice onto the lit slope and falls gently over the top to the
    /// shaded one, so the skewness of the horizontal lightness differences
    /// (blurred past the tips) is positive; lit from the right, negative.
    #[test]
    fn moss_cushions_are_lit_from_the_light_they_are_drawn_under() {
        let skew = |light: [f32; 2]| {
            let tex = generate_tiling_lit(DecayClass::Mossy, 7, 256, 256, Substrate::Stone, light).unwrap();
            let lum = crate::image::filter::gaussian_blur(&crate::image::color::luminance(&tex.select_channels(0..3)), 1.5);
            let d: Vec<f32> = (0..256 * 256).map(|i| lum.data()[(i / 256) * 256 + (i % 256 + 1) % 256] - lum.data()[i]).collect();
            let mean = d.iter().sum::<f32>() / d.len() as f32;
            let m2 = d.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / d.len() as f32;
            d.iter().map(|v| (v - mean).powi(3)).sum::<f32>() / d.len() as f32 / m2.powf(1.5)
        };
        let (left, right) = (skew([-1.0, 0.0]), skew([1.0, 0.0]));
        assert!(left > 0.1 && right < -0.1, "skewness lit from the left {left}, from the right {right}");
    }

    #[test]
    fn windows_tile_the_whole_texture_exactly() {
        for class in DecayClass::ALL {
            let whole = generate(class, 5, 0, 0, 64, 48, Substrate::Paint).unwrap();
            let part = generate(class, 5, 20, 10, 30, 30, Substrate::Paint).unwrap();
            assert_eq!(whole.crop(20, 10, 30, 30).unwrap().data(), part.data(), "{class:?}");
        }
    }
}

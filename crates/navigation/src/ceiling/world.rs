//! A seeded ceiling: suspended-ceiling tiles with a faint repeated texture (the
//! clutter), and distinctive 2-D patterns (lights, vents, signs, detectors) at known
//! poses, drawn into one texture map in world metres.

use rand::Rng;
use rperc_core::image::GrayImage;
use rperc_core::rng::stream;

use crate::error::{NavigationError, Result};

/// The kinds of ceiling pattern, each drawn procedurally.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PatternKind {
    /// A fluorescent light: a bright diffuser in a dark frame, with two lamp bars.
    Light,
    /// An air vent: a grey square crossed by dark slots.
    Vent,
    /// An exit sign: a dark plate with a bright arrow (not symmetric: its angle is
    /// unambiguous).
    Sign,
    /// A smoke detector: a bright disc with a dark ring and an off-centre LED.
    Detector,
}

impl PatternKind {
    /// Every kind, in the order the generator cycles through them.
    pub const ALL: [PatternKind; 4] = [Self::Light, Self::Vent, Self::Sign, Self::Detector];

    /// The kind's name, as `FromStr` reads it and serde writes it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Light => "light",
            Self::Vent => "vent",
            Self::Sign => "sign",
            Self::Detector => "detector",
        }
    }

    /// The pattern's size `(length, width)` in metres.
    pub fn size(self) -> [f64; 2] {
        match self {
            Self::Light => [1.2, 0.3],
            Self::Vent => [0.45, 0.45],
            Self::Sign => [0.5, 0.25],
            Self::Detector => [0.16, 0.16],
        }
    }

    /// The grey level at `(a, b)` in the pattern's frame (metres from its centre,
    /// `a` along its length); `None` outside it.
    fn level(self, a: f64, b: f64) -> Option<f32> {
        let [l, w] = self.size();
        let (ha, hb) = (l / 2.0, w / 2.0);
        match self {
            Self::Light => (a.abs() <= ha && b.abs() <= hb).then(|| {
                let frame = a.abs() > ha - 0.04 || b.abs() > hb - 0.04;
                let bar = (b.abs() - 0.06).abs() < 0.02 && a.abs() < ha - 0.08;
                if frame {
                    70.0
                } else if bar {
                    255.0
                } else {
                    232.0
                }
            }),
            Self::Vent => (a.abs() <= ha && b.abs() <= hb).then(|| {
                let border = a.abs() > ha - 0.03 || b.abs() > hb - 0.03;
                let slot = ((a + ha) / 0.06).fract() < 0.45;
                if border {
                    150.0
                } else if slot {
                    45.0
                } else {
                    125.0
                }
            }),
            Self::Sign => (a.abs() <= ha && b.abs() <= hb).then(|| {
                // An arrow pointing along +a: a shaft and a triangular head.
                let shaft = (-0.18..0.06).contains(&a) && b.abs() < 0.035;
                let head = (0.06..0.2).contains(&a) && b.abs() < 0.09 * (0.2 - a) / 0.14;
                if shaft || head { 240.0 } else { 35.0 }
            }),
            Self::Detector => {
                let r = a.hypot(b);
                (r <= ha).then(|| {
                    let led = (a - 0.03).hypot(b - 0.02) < 0.012;
                    if led || (r > ha - 0.02) { 60.0 } else { 225.0 }
                })
            }
        }
    }
}

impl std::str::FromStr for PatternKind {
    type Err = NavigationError;

    /// `"light"`, `"vent"`, `"sign"` or `"detector"`.
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| invalid("kind", format!("unknown pattern kind {s:?}")))
    }
}

/// A pattern placed on the ceiling: the truth the mosaic is scored against.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
pub struct CeilingPattern {
    /// What it is.
    pub kind: PatternKind,
    /// Its centre, world metres.
    pub centre: [f64; 2],
    /// The direction of its length axis, radians (world frame, counter-clockwise
    /// seen from above).
    pub theta: f64,
}

/// How a ceiling is generated.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize, schemars::JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct CeilingParams {
    /// Extent along world x, metres (the ceiling spans `[0, size[0]] x [0, size[1]]`).
    pub size: [f64; 2],
    /// Metres per texel.
    pub resolution: f64,
    /// Side of the square ceiling tiles, metres (0: no tile grid).
    pub tile: f64,
    /// Amplitude of the repeated tile texture, grey levels (the clutter).
    pub texture_contrast: f64,
    /// Patterns placed.
    pub n_patterns: usize,
    /// Least distance between two pattern centres, metres.
    pub min_spacing: f64,
    /// Seed of the layout and texture.
    pub seed: u64,
}

impl Default for CeilingParams {
    fn default() -> Self {
        Self {
            size: [12.0, 8.0],
            resolution: 0.005,
            tile: 0.6,
            texture_contrast: 12.0,
            n_patterns: 24,
            min_spacing: 1.0,
            seed: 0,
        }
    }
}

fn invalid(name: &'static str, reason: impl Into<String>) -> NavigationError {
    NavigationError::InvalidParameter {
        name,
        reason: reason.into(),
    }
}

impl CeilingParams {
    /// Refuses bad values with the parameter's name.
    pub fn validate(&self) -> Result<()> {
        use rperc_core::{ensure_non_negative, ensure_positive};
        ensure_positive("size", self.size[0])?;
        ensure_positive("size", self.size[1])?;
        ensure_positive("resolution", self.resolution)?;
        ensure_non_negative("tile", self.tile)?;
        ensure_non_negative("texture_contrast", self.texture_contrast)?;
        ensure_non_negative("min_spacing", self.min_spacing)?;
        let (w, h) = self.texels();
        if w < 2 || h < 2 {
            return Err(invalid(
                "resolution",
                "the ceiling needs at least 2x2 texels",
            ));
        }
        rperc_core::check_allocation("size", (w as u128) * (h as u128), 4)?;
        Ok(())
    }

    fn texels(&self) -> (usize, usize) {
        let w = (self.size[0] / self.resolution).ceil();
        let h = (self.size[1] / self.resolution).ceil();
        // Saturating casts: validate's allocation check refuses what is too large.
        (w.min(1e12) as usize + 1, h.min(1e12) as usize + 1)
    }
}

/// A generated ceiling: its texture and the true pattern layout.
#[derive(Debug, Clone, PartialEq)]
pub struct Ceiling {
    /// Grey levels; texel `(i, j)` is the world point `(i, j) * resolution`.
    pub texture: GrayImage,
    /// Metres per texel.
    pub resolution: f64,
    /// The patterns, in the order they were placed.
    pub patterns: Vec<CeilingPattern>,
    tiles: TileTexture,
    /// `texture` halved again and again by 2x2 box averages: a camera whose pixel
    /// spans several texels samples the level that matches it (no aliasing, and a
    /// texture small enough to stay in cache).
    pyramid: Vec<GrayImage>,
}

impl Ceiling {
    /// Generates the ceiling of `params`.
    ///
    /// # Examples
    /// ```
    /// use navigation::ceiling::{Ceiling, CeilingParams};
    ///
    /// let params = CeilingParams { size: [4.0, 3.0], resolution: 0.01, n_patterns: 4,
    ///                              min_spacing: 0.5, ..Default::default() };
    /// let ceiling = Ceiling::generate(&params).unwrap();
    /// assert_eq!(ceiling.patterns.len(), 4);
    /// let p = ceiling.patterns[0];
    /// // Its centre is drawn with the pattern's own grey levels, not the tile's.
    /// assert_ne!(ceiling.level_at(p.centre), Some(ceiling.tile_level(p.centre)));
    /// ```
    pub fn generate(params: &CeilingParams) -> Result<Self> {
        params.validate()?;
        let patterns = place_patterns(params)?;
        let (w, h) = params.texels();
        let tiles = TileTexture::new(params);
        let mut texture = GrayImage::zeros(w, h);
        // A ceiling near the allocation limit takes seconds: Ctrl-C is heard by the
        // row (each a texel's tile level per column).
        let mut work = rperc_core::interrupt::Work::new();
        for (j, row) in texture.data.chunks_exact_mut(w).enumerate() {
            work.advance(w as u64)?;
            for (i, t) in row.iter_mut().enumerate() {
                *t = tiles.level([i as f64 * params.resolution, j as f64 * params.resolution]);
            }
        }
        let mut ceiling = Self {
            texture,
            resolution: params.resolution,
            patterns,
            tiles,
            pyramid: Vec::new(),
        };
        for k in 0..ceiling.patterns.len() {
            rperc_core::interrupt::checkpoint()?;
            ceiling.draw(ceiling.patterns[k], &mut work)?;
        }
        ceiling.pyramid = pyramid(&ceiling.texture, &mut work)?;
        Ok(ceiling)
    }

    /// Pyramid level `level` (0: the texture itself; `level` is clamped to the
    /// coarsest) and its texel size. Texel `(i, j)` of level `L` averages the `2^L x
    /// 2^L` texels from `(i, j) 2^L`, so its centre is the world point
    /// `((i, j) 2^L + (2^L - 1) / 2) * resolution`.
    pub fn level(&self, level: usize) -> (&GrayImage, f64) {
        if level == 0 || self.pyramid.is_empty() {
            return (&self.texture, self.resolution);
        }
        let l = level.min(self.pyramid.len());
        (&self.pyramid[l - 1], self.resolution * (1u64 << l) as f64)
    }

    /// The ceiling's grey level at world `xy` (bilinear between texels); `None` off
    /// the ceiling.
    pub fn level_at(&self, xy: [f64; 2]) -> Option<f32> {
        self.texture
            .sample_bilinear(xy[0] / self.resolution, xy[1] / self.resolution)
    }

    /// The bare tile texture at `xy`, without patterns (the clutter the patterns sit on).
    pub fn tile_level(&self, xy: [f64; 2]) -> f32 {
        self.tiles.level(xy)
    }

    /// Metres spanned by the texture, `[x, y]`.
    pub fn extent(&self) -> [f64; 2] {
        [
            (self.texture.width - 1) as f64 * self.resolution,
            (self.texture.height - 1) as f64 * self.resolution,
        ]
    }

    /// Draws one pattern, each texel the mean of 3x3 sub-samples (anti-aliased edges).
    fn draw(&mut self, p: CeilingPattern, work: &mut rperc_core::interrupt::Work) -> Result<()> {
        let res = self.resolution;
        let radius = 0.5 * p.kind.size()[0].hypot(p.kind.size()[1]);
        let (w, h) = (self.texture.width, self.texture.height);
        let lo = |c: f64| ((c - radius) / res).floor().max(0.0) as usize;
        let hi = |c: f64, n: usize| (((c + radius) / res).ceil().max(0.0) as usize).min(n - 1);
        let (s, c) = p.theta.sin_cos();
        let columns = lo(p.centre[0])..=hi(p.centre[0], w);
        for j in lo(p.centre[1])..=hi(p.centre[1], h) {
            work.advance(9 * columns.clone().count() as u64)?;
            for i in columns.clone() {
                let old = self.texture.data[j * w + i];
                let mut sum = 0.0;
                for sub in 0..9 {
                    let x = (i as f64 + f64::from(sub % 3 - 1) / 3.0) * res - p.centre[0];
                    let y = (j as f64 + f64::from(sub / 3 - 1) / 3.0) * res - p.centre[1];
                    sum += p.kind.level(c * x + s * y, -s * x + c * y).unwrap_or(old);
                }
                self.texture.data[j * w + i] = sum / 9.0;
            }
        }
        Ok(())
    }
}

/// Successive 2x2 box averages of `texture` (an odd last row or column is dropped),
/// down to 8 texels on the shorter side.
fn pyramid(texture: &GrayImage, work: &mut rperc_core::interrupt::Work) -> Result<Vec<GrayImage>> {
    let mut levels: Vec<GrayImage> = Vec::new();
    loop {
        let prev = levels.last().unwrap_or(texture);
        let (w, h) = (prev.width / 2, prev.height / 2);
        if w.min(h) < 8 {
            return Ok(levels);
        }
        let mut next = GrayImage::zeros(w, h);
        for j in 0..h {
            work.advance(4 * w as u64)?;
            for i in 0..w {
                let at = |di: usize, dj: usize| prev.at(2 * i + di, 2 * j + dj);
                next.data[j * w + i] = 0.25 * (at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1));
            }
        }
        levels.push(next);
    }
}

/// The suspended-ceiling tiles: a grid of darker joints and, inside each tile, the
/// same seeded fissure texture (a few 2-D harmonics of the tile period), so that the
/// background repeats and a tracker cannot tell one tile from the next by it.
#[derive(Debug, Clone, PartialEq)]
struct TileTexture {
    tile: f64,
    contrast: f64,
    harmonics: Vec<([f64; 2], f64)>,
}

impl TileTexture {
    const BASE: f32 = 200.0;
    const JOINT_DEPTH: f32 = 35.0;
    const JOINT_WIDTH: f64 = 0.012;

    fn new(params: &CeilingParams) -> Self {
        let mut rng = stream(params.seed, 1);
        let harmonics = (0..6)
            .map(|_| {
                let k = [
                    rng.random_range(3..13) as f64,
                    rng.random_range(3..13) as f64,
                ];
                (k, rng.random_range(0.0..std::f64::consts::TAU))
            })
            .collect();
        Self {
            tile: params.tile,
            contrast: params.texture_contrast,
            harmonics,
        }
    }

    fn level(&self, xy: [f64; 2]) -> f32 {
        if self.tile <= 0.0 {
            return Self::BASE;
        }
        let (u, v) = ((xy[0] / self.tile).fract(), (xy[1] / self.tile).fract());
        let edge = self.tile * u.min(1.0 - u).min(v.min(1.0 - v));
        if edge < Self::JOINT_WIDTH / 2.0 {
            return Self::BASE - Self::JOINT_DEPTH;
        }
        let wave: f64 = self
            .harmonics
            .iter()
            .map(|(k, phase)| (std::f64::consts::TAU * (k[0] * u + k[1] * v) + phase).sin())
            .sum();
        Self::BASE + (self.contrast * wave / (self.harmonics.len() as f64).sqrt()) as f32
    }
}

/// Seeded rejection sampling of the layout: kinds in turn, uniform centres keeping the
/// whole pattern on the ceiling, uniform angles, no two closer than `min_spacing` or
/// overlapping.
fn place_patterns(params: &CeilingParams) -> Result<Vec<CeilingPattern>> {
    const ATTEMPTS: usize = 2000;
    let mut rng = stream(params.seed, 0);
    // Grown as patterns fit, not reserved: a count in the billions is refused when the
    // ceiling runs out of room, not by an allocation of gigabytes.
    let mut placed: Vec<(CeilingPattern, f64)> = Vec::new();
    for k in 0..params.n_patterns {
        rperc_core::interrupt::checkpoint()?;
        let kind = PatternKind::ALL[k % PatternKind::ALL.len()];
        let radius = 0.5 * kind.size()[0].hypot(kind.size()[1]);
        let mut found = None;
        for _ in 0..ATTEMPTS {
            let (lx, ly) = (params.size[0] - 2.0 * radius, params.size[1] - 2.0 * radius);
            if lx <= 0.0 || ly <= 0.0 {
                break;
            }
            let centre = [
                radius + lx * rng.random::<f64>(),
                radius + ly * rng.random::<f64>(),
            ];
            let free = placed.iter().all(|(q, r)| {
                let d = (q.centre[0] - centre[0]).hypot(q.centre[1] - centre[1]);
                d >= params.min_spacing.max(r + radius + 0.05)
            });
            if free {
                let theta = std::f64::consts::PI * (2.0 * rng.random::<f64>() - 1.0);
                found = Some(CeilingPattern {
                    kind,
                    centre,
                    theta,
                });
                break;
            }
        }
        let pattern = found.ok_or_else(|| {
            invalid(
                "n_patterns",
                format!(
                    "only {k} of {} patterns fit at min_spacing {} m",
                    params.n_patterns, params.min_spacing
                ),
            )
        })?;
        placed.push((pattern, radius));
    }
    Ok(placed.into_iter().map(|(p, _)| p).collect())
}

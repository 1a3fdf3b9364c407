//! The fixed 256-colour palette every frame is drawn in.
//!
//! Canvases hold palette *indices*, never RGB, so a frame goes to GIF or PNG without colour
//! quantisation. The layout of the indices is fixed (the constants on [`Palette`]): a few named
//! colours, a ramp of [`Palette::RAMP_LEN`] entries for heat maps, and [`Palette::GROUP_COUNT`]
//! distinct group colours. Entries past the group colours are black and free for callers to set.

/// A table of 256 RGB colours, indexed by the bytes of a [`Canvas`](super::Canvas).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Palette {
    colours: [[u8; 3]; 256],
}

/// Control points of the heat-map ramp (a dimmed viridis), from 0 to 1 in equal steps. Dimmed so
/// that agents in bright group colours stand out on top of it.
const RAMP_STOPS: [[f32; 3]; 5] = [
    [40.0, 10.0, 56.0],
    [38.0, 56.0, 100.0],
    [24.0, 100.0, 100.0],
    [70.0, 140.0, 70.0],
    [175.0, 160.0, 40.0],
];

/// Group colours: saturated and light, told apart on the dark background and on the ramp.
const GROUP_COLOURS: [[u8; 3]; Palette::GROUP_COUNT as usize] = [
    [255, 99, 71],
    [64, 196, 255],
    [255, 214, 0],
    [120, 230, 60],
    [255, 105, 200],
    [0, 230, 200],
    [255, 150, 30],
    [170, 130, 255],
    [245, 245, 245],
    [40, 110, 255],
    [200, 255, 150],
    [255, 190, 190],
    [190, 160, 110],
    [0, 180, 90],
    [220, 60, 140],
    [140, 220, 255],
];

impl Palette {
    /// Background.
    pub const BACKGROUND: u8 = 0;
    /// Grid lines.
    pub const GRID: u8 = 1;
    /// Circular obstacles.
    pub const OBSTACLE: u8 = 2;
    /// Wall segments.
    pub const WALL: u8 = 3;
    /// Paths (polylines).
    pub const PATH: u8 = 4;
    /// Gravity points that attract.
    pub const ATTRACT: u8 = 5;
    /// Gravity points that repel.
    pub const REPEL: u8 = 6;
    /// Blocked (wall) cells of a heat map.
    pub const BLOCKED: u8 = 7;
    /// Unreachable cells of a heat map (negative or NaN values).
    pub const UNREACHABLE: u8 = 8;
    /// Flow-field arrows.
    pub const ARROW: u8 = 9;
    /// Pure white.
    pub const WHITE: u8 = 10;
    /// Pure black.
    pub const BLACK: u8 = 11;
    /// Exits (where agents leave the world), drawn as a hatched area with an outline.
    pub const EXIT: u8 = 12;
    /// First index of the heat-map ramp.
    pub const RAMP_START: u8 = 16;
    /// Number of entries in the heat-map ramp.
    pub const RAMP_LEN: u8 = 64;
    /// First index of the group colours.
    pub const GROUP_START: u8 = Self::RAMP_START + Self::RAMP_LEN;
    /// Number of distinct group colours; groups beyond it reuse them cyclically.
    pub const GROUP_COUNT: u8 = 16;

    /// The standard palette: dark background, light walls, a dimmed viridis ramp and bright group
    /// colours.
    #[must_use]
    pub fn standard() -> Self {
        let mut colours = [[0_u8; 3]; 256];
        colours[usize::from(Self::BACKGROUND)] = [16, 18, 24];
        colours[usize::from(Self::GRID)] = [40, 44, 54];
        colours[usize::from(Self::OBSTACLE)] = [110, 116, 130];
        colours[usize::from(Self::WALL)] = [205, 205, 215];
        colours[usize::from(Self::PATH)] = [250, 250, 250];
        colours[usize::from(Self::ATTRACT)] = [60, 210, 90];
        colours[usize::from(Self::REPEL)] = [235, 55, 55];
        colours[usize::from(Self::BLOCKED)] = [78, 82, 94];
        colours[usize::from(Self::UNREACHABLE)] = [28, 22, 34];
        colours[usize::from(Self::ARROW)] = [165, 170, 185];
        colours[usize::from(Self::WHITE)] = [255, 255, 255];
        colours[usize::from(Self::BLACK)] = [0, 0, 0];
        colours[usize::from(Self::EXIT)] = [46, 204, 113];
        let segments = (RAMP_STOPS.len() - 1) as f32;
        for k in 0..Self::RAMP_LEN {
            let t = f32::from(k) / f32::from(Self::RAMP_LEN - 1) * segments;
            let lo = (t.floor() as usize).min(RAMP_STOPS.len() - 2);
            let f = t - lo as f32;
            let (a, b) = (RAMP_STOPS[lo], RAMP_STOPS[lo + 1]);
            colours[usize::from(Self::RAMP_START + k)] =
                std::array::from_fn(|c| (a[c] + (b[c] - a[c]) * f).round() as u8);
        }
        for (k, rgb) in GROUP_COLOURS.iter().enumerate() {
            colours[usize::from(Self::GROUP_START) + k] = *rgb;
        }
        Palette { colours }
    }

    /// The index of group `group`'s colour (groups past [`Palette::GROUP_COUNT`] wrap around).
    #[inline]
    #[must_use]
    pub fn group(group: u32) -> u8 {
        Self::GROUP_START + (group % u32::from(Self::GROUP_COUNT)) as u8
    }

    /// The ramp index for `value` in `[0, 1]` (values outside are clamped), or
    /// [`Palette::UNREACHABLE`] for negative and NaN values.
    #[inline]
    #[must_use]
    pub fn heat(value: f32) -> u8 {
        if value.is_nan() || value < 0.0 {
            return Self::UNREACHABLE;
        }
        let k = (value.min(1.0) * f32::from(Self::RAMP_LEN - 1)).round() as u8;
        Self::RAMP_START + k
    }

    /// The RGB colour of `index`.
    #[inline]
    #[must_use]
    pub fn rgb(&self, index: u8) -> [u8; 3] {
        self.colours[usize::from(index)]
    }

    /// Sets the RGB colour of `index`.
    pub fn set(&mut self, index: u8, rgb: [u8; 3]) {
        self.colours[usize::from(index)] = rgb;
    }

    /// The palette as 768 bytes `r, g, b, r, g, b, ...`, as GIF and PNG encoders take it.
    #[must_use]
    pub fn to_bytes(&self) -> Vec<u8> {
        self.colours.iter().flatten().copied().collect()
    }
}

impl Default for Palette {
    fn default() -> Self {
        Self::standard()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn group_colours_are_distinct_from_each_other_and_the_background() {
        let p = Palette::standard();
        let mut seen = vec![p.rgb(Palette::BACKGROUND)];
        for g in 0..u32::from(Palette::GROUP_COUNT) {
            let c = p.rgb(Palette::group(g));
            assert!(!seen.contains(&c), "group {g} repeats colour {c:?}");
            seen.push(c);
        }
        assert_eq!(
            Palette::group(0),
            Palette::group(u32::from(Palette::GROUP_COUNT))
        );
        assert_eq!(
            Palette::group(u32::MAX),
            Palette::group(u32::MAX % u32::from(Palette::GROUP_COUNT))
        );
    }

    #[test]
    fn heat_ramp_spans_its_range_and_flags_unreachable() {
        assert_eq!(Palette::heat(0.0), Palette::RAMP_START);
        assert_eq!(
            Palette::heat(1.0),
            Palette::RAMP_START + Palette::RAMP_LEN - 1
        );
        assert_eq!(Palette::heat(7.0), Palette::heat(1.0));
        assert_eq!(Palette::heat(-0.1), Palette::UNREACHABLE);
        assert_eq!(Palette::heat(f32::NAN), Palette::UNREACHABLE);
        assert!(Palette::heat(0.25) < Palette::heat(0.75));
        // The ramp gets brighter from end to end.
        let p = Palette::standard();
        let lum = |i: u8| p.rgb(i).iter().map(|&c| u32::from(c)).sum::<u32>();
        assert!(lum(Palette::heat(0.0)) < lum(Palette::heat(1.0)));
    }

    #[test]
    fn bytes_are_rgb_triples() {
        let p = Palette::standard();
        let b = p.to_bytes();
        assert_eq!(b.len(), 768);
        assert_eq!(
            &b[3 * usize::from(Palette::WALL)..][..3],
            &p.rgb(Palette::WALL)
        );
    }
}

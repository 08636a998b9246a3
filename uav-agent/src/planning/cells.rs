//! The cells every planning map is indexed by: the index of a cell, boxes of cells, the
//! deterministic hasher of every cell-keyed map, and the tiled storage the occupancy grid and the
//! costmap keep their cells in.
//!
//! Why a module of its own: the occupancy grid ([`super::grid`]), the costmap
//! ([`super::costmap`]) and A* ([`super::astar`]) all work on cells; the cells sit below all three,
//! so the search does not reach into a map for them, nor a map into the search. Why tiles and a
//! fixed hasher: the grid's "Unbounded map by hashed tiles".

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

/// Cells per side of a storage tile.
pub(super) const TILE: i32 = 16;
/// log2 of [`TILE`].
const TILE_SHIFT: i32 = 4;
const TILE_AREA: usize = (TILE * TILE) as usize;
/// Cell indices are kept within ±2^30 so that neighbour arithmetic never overflows an i32.
pub(super) const MAX_CELL: f64 = (1u32 << 30) as f64;

/// A deterministic hasher for cell and tile keys (FxHash's multiply-rotate): no random seed, so
/// any iteration order, and hence every result, is the same in every run.
#[derive(Default, Clone, Copy)]
pub(crate) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(u64::from(*b));
        }
    }
    fn write_i32(&mut self, v: i32) {
        self.write_u64(u64::from(v as u32));
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

/// Hash map with the deterministic [`CellHasher`].
pub(crate) type CellMap<K, V> = HashMap<K, V, BuildHasherDefault<CellHasher>>;
/// Hash set with the deterministic [`CellHasher`].
pub(crate) type CellSet<K> = HashSet<K, BuildHasherDefault<CellHasher>>;

/// Index of a grid cell: cell (ix, iy) covers `[ix·res, (ix+1)·res) × [iy·res, (iy+1)·res)` of the
/// odometry frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cell {
    /// Column: floor(x / resolution).
    pub ix: i32,
    /// Row: floor(y / resolution).
    pub iy: i32,
}

impl Cell {
    /// The cell (ix, iy).
    pub const fn new(ix: i32, iy: i32) -> Self {
        Cell { ix, iy }
    }

    /// The cell `dx` columns and `dy` rows away (saturating at the i32 range).
    pub fn offset(self, dx: i32, dy: i32) -> Cell {
        Cell { ix: self.ix.saturating_add(dx), iy: self.iy.saturating_add(dy) }
    }

    /// Squared distance to `other` in cells².
    pub(super) fn dist2(self, other: Cell) -> f64 {
        let dx = f64::from(other.ix) - f64::from(self.ix);
        let dy = f64::from(other.iy) - f64::from(self.iy);
        dx * dx + dy * dy
    }

    /// Index of the tile holding this cell (arithmetic shift floors negative indices).
    pub(super) fn tile(self) -> Cell {
        Cell { ix: self.ix >> TILE_SHIFT, iy: self.iy >> TILE_SHIFT }
    }

    /// Position of this cell inside its tile.
    fn local(self) -> usize {
        ((self.iy & (TILE - 1)) * TILE + (self.ix & (TILE - 1))) as usize
    }
}

/// An inclusive rectangle of cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellBox {
    /// Lowest column and row.
    pub min: Cell,
    /// Highest column and row (inclusive).
    pub max: Cell,
}

impl CellBox {
    /// The box holding exactly `c`.
    pub fn around(c: Cell) -> Self {
        CellBox { min: c, max: c }
    }

    /// Whether `c` lies inside.
    pub fn contains(&self, c: Cell) -> bool {
        (self.min.ix..=self.max.ix).contains(&c.ix) && (self.min.iy..=self.max.iy).contains(&c.iy)
    }

    /// The smallest box holding this one and `c`.
    pub fn including(self, c: Cell) -> Self {
        CellBox {
            min: Cell::new(self.min.ix.min(c.ix), self.min.iy.min(c.iy)),
            max: Cell::new(self.max.ix.max(c.ix), self.max.iy.max(c.iy)),
        }
    }

    /// This box widened by `by` cells on every side.
    pub fn grown(self, by: i32) -> Self {
        CellBox { min: self.min.offset(-by, -by), max: self.max.offset(by, by) }
    }
}

/// Sparse storage: 16 × 16 tiles of `T` created on first write; unwritten cells read as `fill`.
#[derive(Debug, Clone)]
pub(crate) struct TileMap<T: Copy> {
    tiles: CellMap<Cell, Box<[T; TILE_AREA]>>,
    fill: T,
}

impl<T: Copy> TileMap<T> {
    /// An empty map whose cells all read as `fill`.
    pub(crate) fn new(fill: T) -> Self {
        TileMap { tiles: CellMap::default(), fill }
    }

    /// The value of `c`.
    pub(crate) fn get(&self, c: Cell) -> T {
        self.tiles.get(&c.tile()).map_or(self.fill, |t| t[c.local()])
    }

    /// The value of `c`, for writing; creates its tile if needed.
    pub(crate) fn get_mut(&mut self, c: Cell) -> &mut T {
        let fill = self.fill;
        &mut self.tiles.entry(c.tile()).or_insert_with(|| Box::new([fill; TILE_AREA]))[c.local()]
    }

    /// Number of tiles allocated (the tests check what a map stores).
    #[cfg(test)]
    pub(crate) fn tile_count(&self) -> usize {
        self.tiles.len()
    }
}

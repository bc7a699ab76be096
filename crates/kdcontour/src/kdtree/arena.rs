//! What one build works in: the node and component arena each parallel task
//! fills ([`Arena`]), and what every node of the build reads ([`Ctx`]).

use super::{Comp, KdNode, NONE};
use crate::cell::CellTables;
use crate::hermite::Hermite;

use crate::qef::Qef;
use crate::settings::Partition;
use glam::Vec3;

/// The nodes and components built so far (one per parallel task near the root).
pub(super) struct Arena {
    /// Nodes, children before their parent.
    pub(super) nodes: Vec<KdNode>,
    /// Components, packed against their node's box as they are made (their
    /// `parent` is filled in when the parent clusters).
    pub(super) comps: Vec<Comp>,
    /// Per component (build time only): the full-precision sum of its crossings'
    /// normals, which the parent's components sum in turn.
    pub(super) normals: Vec<Vec3>,
    /// Per node (build time only): for each of its 12 edges, the cell coordinate
    /// along the edge of its one sign change, or [`NO_EDGE`]. Only meaningful for
    /// clusterable nodes, whose edges have at most one change each.
    pub(super) edges: Vec<[u16; 12]>,
    /// Per node (build time only), when the Hermite data tracks materials
    /// ([`Hermite::cell_material`]): the material code of its cells (one
    /// dominant material, or [`crate::material::MIXED`] where a border passes
    /// through them).
    pub(super) material: Vec<u16>,
}

/// An edge without a sign change in [`Arena::edges`].
pub(super) const NO_EDGE: u16 = u16::MAX;

impl Arena {
    pub(super) fn new() -> Self {
        Arena {
            nodes: Vec::new(),
            comps: Vec::new(),
            normals: Vec::new(),
            edges: Vec::new(),
            material: Vec::new(),
        }
    }

    /// Appends `other`, fixing its indices; returns the offset of its nodes.
    pub(super) fn append(&mut self, other: Arena) -> u32 {
        let noff = self.nodes.len() as u32;
        let coff = self.comps.len() as u32;
        self.nodes.extend(other.nodes.into_iter().map(|mut n| {
            for c in n.children.iter_mut() {
                if *c != NONE {
                    *c += noff;
                }
            }
            n.comp_start += coff;
            n
        }));
        self.comps.extend(other.comps);
        self.normals.extend(other.normals);
        self.edges.extend(other.edges);
        self.material.extend(other.material);
        noff
    }
}

/// What every node of one build reads.
pub(super) struct Ctx<'a> {
    /// The Hermite data the tree is built on.
    pub(super) h: &'a Hermite,
    /// How boxes are split.
    pub(super) partition: Partition,
    /// Nodes whose error is above it are never leaves ([`crate::Settings::max_threshold`]).
    pub(super) max_threshold: f32,
    /// Per active cell: the sum of its patches' QEFs.
    pub(super) cell_qef: Vec<Qef>,
    /// The Dual Marching Cubes tables.
    pub(super) tables: &'static CellTables,
    /// Per active cell: the grid faces it lies on that the surface crosses there
    /// ([`crate::boundary::open_faces`]).
    pub(super) open: Vec<u8>,
    /// Whether a cell of the tree has a bit in `open` (a chunk's core never does:
    /// its halo holds the grid's faces).
    pub(super) any_open: bool,
    /// Per active cell, in a chunk ([`crate::pipeline::Cells::Core`]): the
    /// faces toward finer chunks and toward chunks of its own level that it
    /// touches; empty when the chunk has neither.
    pub(super) touched: Vec<u8>,
    /// The chunk's faces toward finer chunks (bits as `touched`).
    pub(super) finer_faces: u8,
    /// The chunk's faces toward chunks of its own level (bits as `touched`).
    pub(super) same_faces: u8,
    /// The low corner of the cells the tree is built over (a chunk's core).
    pub(super) core_min: [u16; 3],
    /// Per active cell, when materials are tracked: what it is to a material
    /// border (module `borders`); empty otherwise.
    pub(super) kinds: Vec<super::borders::Kinds>,
}

impl Ctx<'_> {
    /// Whether grid corner `c` is outside.
    pub(super) fn outside(&self, c: [u32; 3]) -> bool {
        self.h.is_outside(c)
    }
}

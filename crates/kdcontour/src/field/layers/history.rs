//! The edited layer list: each layer compiled once per change, the undo / redo
//! history, and the regions of space a change can reach.

use super::{scene_node, Layer};
use crate::error::Error;
use crate::field::csg::{Csg, CsgNode};
use crate::field::raycast;
use glam::Vec3;

/// A layer compiled: its field (for picking) and the sphere it can change.
struct Part {
    field: Csg,
    reach: Option<(Vec3, f32)>,
}

impl Part {
    /// Where the layer can change the scene: its bounding sphere grown by its blend
    /// radius, or `None` when it is unbounded.
    fn of(layer: &Layer) -> Result<Part, Error> {
        let field = layer.node().compile()?;
        let grow = if layer.operation.is_smooth() {
            layer.blend
        } else {
            0.0
        };
        let reach = field.bounding_sphere().map(|(c, r)| (c, r + grow));
        Ok(Part { field, reach })
    }
}

/// One state of the list, with each layer compiled.
struct State {
    list: Vec<Layer>,
    parts: Vec<Part>,
}

impl State {
    fn of(list: Vec<Layer>) -> Result<State, Error> {
        scene_node(&list).check("root")?;
        let parts = list.iter().map(Part::of).collect::<Result<_, _>>()?;
        Ok(State { list, parts })
    }
}

/// What a change to the list did.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// Spheres `(center, radius)` outside which the scene's surface and its
    /// inside / outside did not change, or `None` for everywhere.
    ///
    /// Outside a layer's bounding sphere (grown by its blend radius) its distance
    /// is positive, so the scene's inside / outside and its surface there do not
    /// depend on it; the spheres are the changed layers' old and new ones. (A
    /// smooth operation later in the list could in principle carry a change a
    /// blend radius further; the regions do not grow for that.)
    pub regions: Option<Vec<(Vec3, f32)>>,
}

/// Most undo steps kept.
pub const UNDO_DEPTH: usize = 200;

/// The edited layer list, each layer compiled once per change, with undo and redo.
pub struct Layers {
    now: State,
    undo: Vec<State>,
    redo: Vec<State>,
}

impl Layers {
    /// Checks and compiles `list`; the error names the bad node.
    pub fn new(list: Vec<Layer>) -> Result<Layers, Error> {
        Ok(Layers {
            now: State::of(list)?,
            undo: Vec::new(),
            redo: Vec::new(),
        })
    }

    /// The layers, in order.
    pub fn list(&self) -> &[Layer] {
        &self.now.list
    }

    /// The whole scene as one node (see [`scene_node`]).
    pub fn scene_node(&self) -> CsgNode {
        scene_node(&self.now.list)
    }

    /// The scene's field with its origin moved to `offset` (a volume's local space
    /// when the volume's corner is at `-offset`).
    ///
    /// # Panics
    ///
    /// If `offset` is not finite.
    pub fn field_at(&self, offset: Vec3) -> Csg {
        assert!(offset.is_finite(), "offset must be finite, got {offset}");
        CsgNode::Transform {
            translate: offset,
            rotate_axis: Vec3::Y,
            rotate_degrees: 0.0,
            scale: 1.0,
            child: Box::new(self.scene_node()),
        }
        .compile()
        .expect("every state was checked when it was set, and the offset is finite")
    }

    /// The sphere layer `i` can change (its bounds grown by its blend radius), or
    /// `None` when it is unbounded or out of range.
    pub fn reach(&self, i: usize) -> Option<(Vec3, f32)> {
        self.now.parts.get(i)?.reach
    }

    /// The layer whose own surface the ray from `origin` along `dir` meets first,
    /// within `max_dist` (marching steps of at most `max_step`; see [`raycast`]).
    pub fn pick(&self, origin: Vec3, dir: Vec3, max_dist: f32, max_step: f32) -> Option<usize> {
        let mut best: Option<(f32, usize)> = None;
        for (i, p) in self.now.parts.iter().enumerate() {
            if let Some(t) = raycast(&p.field, origin, dir, max_dist, max_step) {
                if best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, i));
                }
            }
        }
        best.map(|(_, i)| i)
    }

    /// Replaces the list as one undo step. On error nothing changes.
    pub fn edit(&mut self, list: Vec<Layer>) -> Result<Change, Error> {
        let next = State::of(list)?;
        let before = std::mem::replace(&mut self.now, next);
        let change = self.change_from(&before);
        self.undo.push(before);
        self.redo.clear();
        if self.undo.len() > UNDO_DEPTH {
            self.undo.remove(0);
        }
        Ok(change)
    }

    /// Replaces the list within the last undo step (the later frames of a drag,
    /// undone together with its first). On error nothing changes.
    pub fn continue_edit(&mut self, list: Vec<Layer>) -> Result<Change, Error> {
        let next = State::of(list)?;
        let before = std::mem::replace(&mut self.now, next);
        Ok(self.change_from(&before))
    }

    /// Whether there is a step to undo.
    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    /// Whether there is a step to redo.
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    /// Goes back one step, or `None` when there is none.
    pub fn undo(&mut self) -> Option<Change> {
        let prev = self.undo.pop()?;
        let now = std::mem::replace(&mut self.now, prev);
        let change = self.change_from(&now);
        self.redo.push(now);
        Some(change)
    }

    /// Goes forward one undone step, or `None` when there is none.
    pub fn redo(&mut self) -> Option<Change> {
        let next = self.redo.pop()?;
        let now = std::mem::replace(&mut self.now, next);
        let change = self.change_from(&now);
        self.undo.push(now);
        Some(change)
    }

    /// The regions the change from `before` to now can reach.
    fn change_from(&self, before: &State) -> Change {
        let regions = changed(&before.list, &self.now.list).and_then(|layers| {
            layers
                .into_iter()
                .map(|w| match w {
                    Which::Old(i) => before.parts[i].reach,
                    Which::New(i) => self.now.parts[i].reach,
                })
                .collect::<Option<Vec<_>>>()
        });
        Change { regions }
    }
}

/// A layer of the list before or after a change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Which {
    Old(usize),
    New(usize),
}

/// The layers a change touched: in a list of the same length every differing
/// layer, old and new; when one layer was inserted or removed (everything else the
/// same, in order), that layer; otherwise `None`.
fn changed(a: &[Layer], b: &[Layer]) -> Option<Vec<Which>> {
    if a.len() == b.len() {
        return Some(
            a.iter()
                .zip(b)
                .enumerate()
                .filter(|(_, (x, y))| x != y)
                .flat_map(|(i, _)| [Which::Old(i), Which::New(i)])
                .collect(),
        );
    }
    let removed = a.len() > b.len();
    let (short, long) = if removed { (b, a) } else { (a, b) };
    let i = (0..short.len())
        .find(|&i| short[i] != long[i])
        .unwrap_or(short.len());
    (long.len() == short.len() + 1 && short[i..] == long[i + 1..]).then(|| {
        vec![if removed {
            Which::Old(i)
        } else {
            Which::New(i)
        }]
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::layers::{starter, Operation, Solid};
    use crate::Field;

    /// Half the side of the editor's cube (world units).
    const HALF: f32 = 1.5;

    #[test]
    fn a_moved_shape_re_meshes_only_near_its_old_and_new_places() {
        let mut layers = Layers::new(starter()).unwrap();
        let a = layers.field_at(Vec3::splat(HALF));
        let old = layers.reach(4).unwrap();
        let mut moved = layers.list().to_vec();
        moved[4].translate.x -= 0.3;
        let change = layers.edit(moved).unwrap();
        let new = layers.reach(4).unwrap();
        assert_eq!(change.regions, Some(vec![old, new]));
        // Outside both spheres the scene's inside / outside is unchanged (its
        // values may differ deep inside the solid, where a difference's distance
        // to the moved shape still counts, but no crossing moves there), and the
        // surface itself is unchanged: where one field is on it, so is the other.
        let b = layers.field_at(Vec3::splat(HALF));
        let mut checked = 0;
        for i in 0..4000 {
            let p = Vec3::new(
                (i as f32 * 0.173).sin(),
                (i as f32 * 0.311).cos(),
                (i as f32 * 0.097).sin(),
            ) * HALF;
            if p.distance(old.0) > old.1 && p.distance(new.0) > new.1 {
                let q = p + Vec3::splat(HALF); // the volume's local space
                let (fa, fb) = (a.value(q), b.value(q));
                assert_eq!(fa < 0.0, fb < 0.0, "{p}: {fa} vs {fb}");
                if fa.abs() < 0.05 {
                    assert!((fa - fb).abs() < 1e-5, "{p}: {fa} vs {fb} near the surface");
                }
                checked += 1;
            }
        }
        assert!(checked > 500, "{checked}");
    }

    #[test]
    fn a_recoloured_shape_re_meshes_only_near_it_and_changes_no_surface() {
        let mut layers = Layers::new(starter()).unwrap();
        let a = layers.field_at(Vec3::splat(HALF));
        let reach = layers.reach(3).unwrap();
        let mut recoloured = layers.list().to_vec();
        recoloured[3].material = 6;
        let change = layers.edit(recoloured).unwrap();
        assert_eq!(change.regions, Some(vec![reach, reach]));
        let b = layers.field_at(Vec3::splat(HALF));
        let (mut inside, mut outside) = (0, 0);
        for i in 0..20000 {
            let p = Vec3::new(
                (i as f32 * 0.173).sin(),
                (i as f32 * 0.311).cos(),
                (i as f32 * 0.097).sin(),
            ) * HALF;
            let q = p + Vec3::splat(HALF);
            // The same surface everywhere: only the material moved.
            assert_eq!(a.value(q), b.value(q), "{p}");
            let (ma, mb) = (a.material(q), b.material(q));
            // Away from the surface the winning side of a union can be a far
            // shape (every distance is positive there); the mesh only reads
            // materials on the surface.
            if p.distance(reach.0) > reach.1 {
                if a.value(q).abs() < 0.05 {
                    assert_eq!(ma, mb, "{p}: the material changed outside the ring's reach");
                    outside += 1;
                }
            } else if ma != mb {
                assert!(mb.weight_of(6) > 0.0 && ma.weight_of(3) > 0.0, "{p}");
                inside += 1;
            }
        }
        assert!(
            outside > 50 && inside > 50,
            "{outside} outside, {inside} recoloured"
        );
    }

    #[test]
    fn inserting_or_removing_one_layer_touches_only_that_layer() {
        let mut layers = Layers::new(starter()).unwrap();
        let gone = layers.reach(2).unwrap();
        let mut list = layers.list().to_vec();
        list.remove(2);
        assert_eq!(layers.edit(list).unwrap().regions, Some(vec![gone]));
        // Undo puts it back: the same region.
        assert_eq!(layers.undo().unwrap().regions, Some(vec![gone]));
        assert_eq!(layers.list(), &starter()[..]);
        // Two layers swapped and one removed: everywhere.
        let mut list = starter();
        list.swap(0, 1);
        list.pop();
        assert_eq!(layers.edit(list).unwrap().regions, None);
        // Nothing changed: nowhere.
        let same = layers.list().to_vec();
        assert_eq!(layers.edit(same).unwrap().regions, Some(vec![]));
    }

    #[test]
    fn undo_and_redo_walk_the_history_and_a_drag_is_one_step() {
        let mut layers = Layers::new(starter()).unwrap();
        assert!(!layers.can_undo() && !layers.can_redo());
        assert!(layers.undo().is_none());
        let step = |layers: &Layers, dx: f32| {
            let mut l = layers.list().to_vec();
            l[1].translate.x += dx;
            l
        };
        layers.edit(step(&layers, 0.1)).unwrap();
        for _ in 0..5 {
            layers.continue_edit(step(&layers, 0.1)).unwrap();
        }
        let dragged = layers.list().to_vec();
        layers.undo().unwrap();
        assert_eq!(layers.list(), &starter()[..]);
        assert!(!layers.can_undo() && layers.can_redo());
        layers.redo().unwrap();
        assert_eq!(layers.list(), &dragged[..]);
        // A new edit forgets what was undone.
        layers.undo().unwrap();
        layers.edit(step(&layers, -0.2)).unwrap();
        assert!(!layers.can_redo());
        // An impossible edit changes nothing.
        let mut bad = layers.list().to_vec();
        bad[0].scale = -1.0;
        let before = layers.list().to_vec();
        assert!(layers.edit(bad).is_err());
        assert_eq!(layers.list(), &before[..]);
        // The history is bounded.
        for i in 0..UNDO_DEPTH + 10 {
            layers.edit(step(&layers, 0.001 * i as f32)).unwrap();
        }
        let mut n = 0;
        while layers.undo().is_some() {
            n += 1;
        }
        assert_eq!(n, UNDO_DEPTH);
    }

    #[test]
    fn picking_finds_the_nearest_layer_surface() {
        let layers = Layers::new(vec![
            Layer::new(Solid::Sphere, Operation::Union, 0.1, Vec3::ZERO, 1.0),
            Layer::new(
                Solid::Box,
                Operation::Union,
                0.1,
                Vec3::new(0.0, 0.0, 2.0),
                1.0,
            ),
        ])
        .unwrap();
        let from_front = layers.pick(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 50.0, 0.05);
        assert_eq!(from_front, Some(1));
        let from_back = layers.pick(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, 50.0, 0.05);
        assert_eq!(from_back, Some(0));
        assert_eq!(
            layers.pick(Vec3::new(0.0, 5.0, 0.0), Vec3::X, 50.0, 0.05),
            None
        );
        // An empty list is a valid (far away) scene.
        assert!(Layers::new(Vec::new()).unwrap().reach(0).is_none());
    }
}

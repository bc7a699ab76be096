//! Agents (the terrain demo's `G` key): capsules that walk the volume's navmesh
//! to a point, around what was dug and up what was raised, each drawing the
//! path it follows. The first `G` turns the navmesh on and places four agents
//! at the point under the cursor; every next `G` sends them to it. Their paths
//! are planned again whenever navmesh tiles change (an edit re-meshed the
//! ground).

use bevy::prelude::*;
use bevy_kdcontour::{NavAnchor, NavmeshSettings, VolumeNavMesh};

/// Walking speed (units a second).
const SPEED: f32 = 4.0;
/// The capsule: radius and middle (1.8 tall), its centre above its feet.
const RADIUS: f32 = 0.4;
const MIDDLE: f32 = 1.0;
const CENTRE: f32 = RADIUS + MIDDLE / 2.0;
/// Where the agents stand around the point they are placed at.
const SPOTS: [(f32, f32); 4] = [(-1.5, -1.5), (1.5, -1.5), (-1.5, 1.5), (1.5, 1.5)];
const COLOURS: [Color; 4] = [
    Color::srgb(0.95, 0.3, 0.25),
    Color::srgb(0.25, 0.55, 0.95),
    Color::srgb(0.95, 0.8, 0.2),
    Color::srgb(0.7, 0.35, 0.9),
];

/// The agents' volume, goal and what their last plan said.
#[derive(Resource, Default)]
pub struct Agents {
    /// The volume they walk on.
    pub volume: Option<Entity>,
    /// Where they go (volume space: the demo's volume sits at the origin).
    pub goal: Option<Vec3>,
    /// Plan again this frame (a new goal).
    replan: bool,
    /// [`VolumeNavMesh::version`] at the last plan: a change plans again.
    planned_at: Option<u64>,
    /// What the last plan said (paths found, or why one was not).
    pub status: String,
    /// Frames since every agent last had a path (for the screenshot's gate).
    pub walked: u32,
    /// The goal's marker entity.
    marker: Option<Entity>,
}

/// One agent: the path it follows and how far along it is.
#[derive(Component)]
pub struct Agent {
    path: Vec<Vec3>,
    next: usize,
    colour: Color,
}

/// The goal's marker: a navigation anchor, so the tiles around it are built.
#[derive(Component)]
struct Goal;

/// The agents' systems (add once).
pub struct AgentsPlugin;

impl Plugin for AgentsPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<Agents>()
            .add_systems(Update, (plan, walk, draw).chain());
    }
}

/// Places four agents around `at` (turning the navmesh on), or, once they are
/// there, sends them to `at`.
pub fn place_or_send(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
    agents: &mut Agents,
    navmesh: &mut NavmeshSettings,
    volume: Entity,
    at: Vec3,
) {
    if agents.volume.is_none() {
        navmesh.enabled = true;
        agents.volume = Some(volume);
        let capsule = meshes.add(Capsule3d::new(RADIUS, MIDDLE));
        for ((dx, dz), colour) in SPOTS.into_iter().zip(COLOURS) {
            commands.spawn((
                Agent {
                    path: Vec::new(),
                    next: 0,
                    colour,
                },
                NavAnchor,
                Mesh3d(capsule.clone()),
                MeshMaterial3d(materials.add(StandardMaterial {
                    base_color: colour,
                    ..default()
                })),
                Transform::from_translation(at + Vec3::new(dx, CENTRE, dz)),
            ));
        }
        agents.status = "agents placed: G sends them to the cursor".into();
        return;
    }
    agents.goal = Some(at);
    agents.replan = true;
    match agents.marker {
        Some(m) => {
            commands.entity(m).insert(Transform::from_translation(at));
        }
        None => {
            agents.marker = Some(
                commands
                    .spawn((Goal, NavAnchor, Transform::from_translation(at)))
                    .id(),
            );
        }
    }
}

/// Plans every agent's path to the goal: when it is set, and again whenever
/// the navmesh changed (the ground changed, or tiles arrived).
fn plan(
    mut agents: ResMut<Agents>,
    volumes: Query<(&GlobalTransform, &VolumeNavMesh)>,
    mut walkers: Query<(&Transform, &mut Agent)>,
) {
    let (Some(goal), Some(volume)) = (agents.goal, agents.volume) else {
        return;
    };
    let Ok((vol_tf, nav)) = volumes.get(volume) else {
        return;
    };
    if !agents.replan && agents.planned_at == Some(nav.version()) {
        return;
    }
    agents.replan = false;
    agents.planned_at = Some(nav.version());
    let (mut found, mut why) = (0, None);
    for (tf, mut agent) in &mut walkers {
        let feet = tf.translation - Vec3::Y * CENTRE;
        match nav.find_path_world(vol_tf, feet, goal) {
            Ok(path) => {
                agent.path = path;
                agent.next = 1;
                found += 1;
            }
            Err(e) => {
                agent.path.clear();
                why = Some(e.to_string());
            }
        }
    }
    agents.status = match why {
        None => format!("{found} agents on their way"),
        Some(e) => format!("{found} agents on their way; {e}"),
    };
}

/// Walks each agent along its path.
fn walk(
    time: Res<Time>,
    mut agents: ResMut<Agents>,
    mut walkers: Query<(&mut Transform, &mut Agent)>,
) {
    // At most a tenth of a second a frame: a slow frame does not jump.
    let step = SPEED * time.delta_secs().min(0.1);
    let mut all_have_paths = !walkers.is_empty();
    for (mut tf, mut agent) in &mut walkers {
        all_have_paths &= !agent.path.is_empty();
        let mut budget = step;
        while budget > 0.0 && agent.next < agent.path.len() {
            let target = agent.path[agent.next] + Vec3::Y * CENTRE;
            let to = target - tf.translation;
            let d = to.length();
            if d <= budget {
                tf.translation = target;
                budget -= d;
                agent.next += 1;
            } else {
                tf.translation += to / d * budget;
                budget = 0.0;
            }
        }
    }
    agents.walked = if all_have_paths { agents.walked + 1 } else { 0 };
}

/// Draws each agent's path ahead of it, and the goal.
fn draw(mut gizmos: Gizmos, agents: Res<Agents>, walkers: Query<(&Transform, &Agent)>) {
    let lift = Vec3::Y * 0.2;
    for (tf, agent) in &walkers {
        if agent.next >= agent.path.len() {
            continue;
        }
        let here = tf.translation - Vec3::Y * (CENTRE - 0.2);
        gizmos.linestrip(
            std::iter::once(here).chain(agent.path[agent.next..].iter().map(|p| *p + lift)),
            agent.colour,
        );
    }
    if let Some(goal) = agents.goal {
        gizmos.circle(
            Isometry3d::new(
                goal + lift,
                Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            ),
            2.0,
            Color::WHITE,
        );
        gizmos.line(goal, goal + Vec3::Y * 4.0, Color::WHITE);
    }
}

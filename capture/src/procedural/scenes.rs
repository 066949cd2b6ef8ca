//! The built-in scenes. Each is deterministic and small enough to commit as a trace, and
//! each stresses one thing a shading scheme cares about.

use glam::{Vec2, Vec3};
use shadetrace_formats::{Geometry, Light, LightKind, Scene};

use super::builder::{material, MeshBuilder};
use super::rng::SplitMix64;
use super::sphere::cube_sphere;
use super::texture::checker;
use crate::camera_path::Orbit;

/// A built-in scene and the orbit its default camera path follows.
pub struct Built {
    pub scene: Scene,
    pub orbit: Orbit,
}

fn sun(direction: Vec3) -> Light {
    Light {
        name: "sun".into(),
        kind: LightKind::Directional {
            direction: direction.normalize(),
        },
        color: Vec3::new(1.0, 0.97, 0.92),
        intensity: 3.0,
        shadowed: true,
    }
}

/// Textured floor of large triangles with a few boxes casting shadows: the best case for
/// coarse shading.
pub fn floor() -> Built {
    let mut ground = MeshBuilder::new("ground", 0);
    ground.grid(
        Vec3::new(-20.0, 0.0, 20.0),
        Vec3::X * 40.0,
        Vec3::NEG_Z * 40.0,
        4,
        4,
        Vec2::splat(20.0),
    );
    let mut boxes = MeshBuilder::new("boxes", 1);
    for (x, z, h) in [(-1.5, -1.0, 1.0), (1.2, -2.0, 1.6), (0.2, 0.8, 0.6)] {
        boxes.cuboid(
            Vec3::new(x - 0.4, 0.0, z - 0.4),
            Vec3::new(x + 0.4, h, z + 0.4),
            false,
            1,
        );
    }
    Built {
        scene: Scene {
            geometry: Geometry {
                meshes: vec![ground.build(), boxes.build()],
            },
            materials: vec![
                material("ground", [1.0; 4], Some(0), 32.0, 0.2),
                material("boxes", [1.0; 4], Some(1), 8.0, 0.1),
            ],
            textures: vec![
                checker("ground-checker", 512, 8, [200, 190, 170], [90, 80, 70], 0.4, 1),
                checker("box-checker", 256, 4, [180, 60, 50], [230, 220, 200], 0.3, 2),
            ],
            lights: vec![sun(Vec3::new(-0.5, -1.0, -0.3))],
            surface_maps: Default::default(),
        },
        orbit: Orbit {
            center: Vec3::ZERO,
            target: Vec3::new(0.0, 0.5, -0.5),
            radius: 5.0,
            height: 1.7,
            start_deg: 0.0,
            sweep_deg: 360.0,
        },
    }
}

/// Tessellation levels of the default spheres scene, as quads per patch edge.
pub const SPHERE_LEVELS: [u32; 5] = [2, 4, 8, 16, 32];

/// Five specular, textured spheres with patch ids, one per tessellation level (or all at
/// one level with `subdiv`): the Ogre/Castle tessellation experiment.
pub fn spheres(subdiv: Option<u32>) -> Built {
    let mut meshes = Vec::new();
    let mut floor = MeshBuilder::new("floor", 0);
    floor.grid(
        Vec3::new(-4.0, 0.0, 2.0),
        Vec3::X * 8.0,
        Vec3::NEG_Z * 4.0,
        2,
        1,
        Vec2::ONE,
    );
    meshes.push(floor.build());
    let mut first_patch = 0;
    for (i, &level) in SPHERE_LEVELS.iter().enumerate() {
        let quads = subdiv.map_or(level, |s| 1 << s);
        let mut mb = MeshBuilder::new(&format!("sphere-{quads}"), 1);
        let center = Vec3::new(-2.4 + 1.2 * i as f32, 0.5, 0.0);
        first_patch += cube_sphere(&mut mb, center, 0.5, quads, Some(first_patch));
        meshes.push(mb.build());
    }
    Built {
        scene: Scene {
            geometry: Geometry { meshes },
            materials: vec![
                material("floor", [1.0; 4], Some(0), 16.0, 0.1),
                material("sphere", [1.0; 4], Some(1), 64.0, 0.6),
            ],
            textures: vec![
                checker("floor-checker", 512, 16, [170, 170, 160], [110, 110, 100], 0.3, 3),
                checker("sphere-checker", 512, 12, [60, 110, 200], [230, 200, 90], 0.2, 4),
            ],
            lights: vec![sun(Vec3::new(-0.4, -1.0, -0.6))],
            surface_maps: Default::default(),
        },
        orbit: Orbit {
            center: Vec3::new(0.0, 0.5, 0.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            radius: 3.5,
            height: 1.4,
            start_deg: 0.0,
            sweep_deg: 360.0,
        },
    }
}

/// A ball of thin ribbons made of tiny triangles (a few pixels each at 1280x1440): the
/// worst case for quad shading and coarse shading alike.
pub fn hairball() -> Built {
    const STRANDS: u32 = 2000;
    const SEGMENTS: u32 = 12;
    const STEP: f32 = 0.012;
    const WIDTH: f32 = 0.006;
    let mut rng = SplitMix64::new(0x4841_4952);
    let mut hair = MeshBuilder::new("hairball", 0);
    let center = Vec3::new(0.0, 1.0, 0.0);
    for _ in 0..STRANDS {
        let mut p = center + random_unit(&mut rng) * rng.range(0.2, 0.6);
        let mut dir = random_unit(&mut rng);
        let mut prev: Option<(u32, u32)> = None;
        for _ in 0..=SEGMENTS {
            let side = dir.cross(random_unit(&mut rng)).normalize_or(Vec3::X);
            let normal = side.cross(dir).normalize_or(Vec3::Y);
            let a = hair.vertex(p - side * (0.5 * WIDTH), normal, Vec2::ZERO);
            let b = hair.vertex(p + side * (0.5 * WIDTH), normal, Vec2::ZERO);
            if let Some((pa, pb)) = prev {
                hair.triangle(pa, pb, b);
                hair.triangle(pa, b, a);
            }
            prev = Some((a, b));
            dir = (dir + random_unit(&mut rng) * 0.35).normalize_or(Vec3::Y);
            p += dir * STEP;
        }
    }
    let mut floor = MeshBuilder::new("floor", 1);
    floor.grid(
        Vec3::new(-3.0, 0.0, 3.0),
        Vec3::X * 6.0,
        Vec3::NEG_Z * 6.0,
        1,
        1,
        Vec2::ONE,
    );
    let mut hair_material = material("hair", [0.45, 0.3, 0.2, 1.0], None, 48.0, 0.4);
    hair_material.double_sided = true;
    Built {
        scene: Scene {
            geometry: Geometry {
                meshes: vec![hair.build(), floor.build()],
            },
            materials: vec![hair_material, material("floor", [0.6, 0.6, 0.6, 1.0], None, 4.0, 0.05)],
            textures: vec![],
            lights: vec![sun(Vec3::new(-0.3, -1.0, -0.5))],
            surface_maps: Default::default(),
        },
        orbit: Orbit {
            center: Vec3::new(0.0, 1.0, 0.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            radius: 3.0,
            height: 1.3,
            start_deg: 0.0,
            sweep_deg: 360.0,
        },
    }
}

/// Six staggered picket-fence layers in front of a wall: high depth complexity, and
/// each eye sees through different gaps (disocclusions between the views).
pub fn depth_stack() -> Built {
    const LAYERS: u32 = 6;
    let mut meshes = Vec::new();
    let mut wall = MeshBuilder::new("wall", 0);
    wall.grid(
        Vec3::new(-4.0, 0.0, -5.0),
        Vec3::X * 8.0,
        Vec3::Y * 4.0,
        2,
        1,
        Vec2::new(4.0, 2.0),
    );
    meshes.push(wall.build());
    let mut materials = vec![material("wall", [1.0; 4], Some(0), 4.0, 0.05)];
    for layer in 0..LAYERS {
        let z = -0.5 - 0.7 * layer as f32;
        let offset = 0.07 * layer as f32;
        let mut fence = MeshBuilder::new(&format!("layer-{layer}"), layer + 1);
        let mut x = -3.0 + offset;
        while x < 3.0 {
            fence.grid(
                Vec3::new(x, 0.2, z),
                Vec3::X * 0.15,
                Vec3::Y * 2.4,
                1,
                1,
                Vec2::new(0.25, 2.0),
            );
            x += 0.4;
        }
        meshes.push(fence.build());
        let hue = layer as f32 / LAYERS as f32;
        let tint = [0.5 + 0.5 * hue, 0.9 - 0.5 * hue, 0.6, 1.0];
        materials.push(material(&format!("layer-{layer}"), tint, Some(1), 24.0, 0.3));
    }
    Built {
        scene: Scene {
            geometry: Geometry { meshes },
            materials,
            textures: vec![
                checker("wall-checker", 512, 16, [210, 210, 200], [60, 70, 90], 0.3, 5),
                checker("fence-grain", 256, 2, [220, 200, 170], [170, 140, 110], 0.6, 6),
            ],
            lights: vec![sun(Vec3::new(0.3, -0.8, -0.6))],
            surface_maps: Default::default(),
        },
        orbit: Orbit {
            center: Vec3::new(0.0, 1.4, -2.0),
            target: Vec3::new(0.0, 1.3, -2.5),
            radius: 4.0,
            height: 1.5,
            start_deg: -20.0,
            sweep_deg: 40.0,
        },
    }
}

/// The paper-like scene (the tile-pair paper's Arena): an enclosed, open-topped arena of large
/// textured triangles (floor, walls, tiered seating, pillars) in sunlight with shadows, and a
/// skinned dragon swimming through the middle ([`super::dragon`]). The default path stands
/// inside at eye height and circles the dragon.
pub fn arena() -> Built {
    let half = 24.0;
    let mut ground = MeshBuilder::new("ground", 0);
    ground.grid(
        Vec3::new(-half, 0.0, half),
        Vec3::X * 2.0 * half,
        Vec3::NEG_Z * 2.0 * half,
        6,
        6,
        Vec2::splat(12.0),
    );
    let mut walls = MeshBuilder::new("walls", 1);
    let height = 10.0;
    for (origin, along) in [
        (Vec3::new(-half, 0.0, -half), Vec3::X),
        (Vec3::new(half, 0.0, -half), Vec3::Z),
        (Vec3::new(half, 0.0, half), Vec3::NEG_X),
        (Vec3::new(-half, 0.0, half), Vec3::NEG_Z),
    ] {
        // Facing the centre: u along the wall, v up, u x v inwards.
        walls.grid(origin, along * 2.0 * half, Vec3::Y * height, 6, 2, Vec2::new(12.0, 2.5));
    }
    // Three tiers of seating on a ring, each tier a riser and a tread of 48 segments.
    let mut seats = MeshBuilder::new("seats", 1);
    let segments = 48;
    for tier in 0..3 {
        let (r, y) = (17.0 + 2.0 * tier as f32, 0.8 * tier as f32);
        for i in 0..segments {
            let angle = |k: u32| std::f32::consts::TAU * k as f32 / segments as f32;
            let (a0, a1) = (angle(i), angle(i + 1));
            let on = |radius: f32, a: f32, h: f32| Vec3::new(radius * libm::cosf(a), h, radius * libm::sinf(a));
            // Riser facing the centre, then the tread facing up (u along the ring).
            let (base, top) = (on(r, a0, y), on(r, a0, y + 0.8));
            seats.grid(base, on(r, a1, y) - base, Vec3::Y * 0.8, 1, 1, Vec2::new(2.0, 0.5));
            seats.grid(
                top,
                on(r, a1, y + 0.8) - top,
                on(r + 2.0, a0, y + 0.8) - top,
                1,
                1,
                Vec2::new(2.0, 1.0),
            );
        }
    }
    let mut pillars = MeshBuilder::new("pillars", 2);
    for i in 0..8 {
        let a = std::f32::consts::TAU * (i as f32 + 0.5) / 8.0;
        let (x, z) = (13.0 * libm::cosf(a), 13.0 * libm::sinf(a));
        pillars.cuboid(
            Vec3::new(x - 0.7, 0.0, z - 0.7),
            Vec3::new(x + 0.7, 7.0, z + 0.7),
            false,
            1,
        );
    }
    Built {
        scene: Scene {
            geometry: Geometry {
                meshes: vec![
                    ground.build(),
                    walls.build(),
                    seats.build(),
                    pillars.build(),
                    super::dragon::Dragon::mesh(3),
                ],
            },
            materials: vec![
                material("ground", [1.0; 4], Some(0), 16.0, 0.1),
                material("stone", [1.0; 4], Some(1), 8.0, 0.05),
                material("pillars", [1.0; 4], Some(2), 24.0, 0.2),
                material("dragon", [0.35, 0.75, 0.4, 1.0], Some(3), 48.0, 0.5),
            ],
            textures: vec![
                checker("arena-sand", 512, 8, [214, 190, 150], [180, 156, 118], 0.5, 11),
                checker("arena-stone", 512, 4, [170, 165, 155], [120, 115, 110], 0.4, 12),
                checker("arena-marble", 256, 2, [235, 232, 225], [150, 140, 130], 0.6, 13),
                checker("dragon-scales", 256, 16, [120, 200, 110], [40, 110, 60], 0.5, 14),
            ],
            lights: vec![sun(Vec3::new(-0.45, -1.0, -0.35))],
            surface_maps: Default::default(),
        },
        orbit: Orbit {
            center: Vec3::ZERO,
            target: Vec3::new(0.0, 1.3, 0.0),
            radius: 9.0,
            height: 1.7,
            start_deg: 0.0,
            sweep_deg: 360.0,
        },
    }
}

/// A closed room lit by 48 coloured point lights and no sun: many unshadowed lights, so
/// replay must skip the shadow pass entirely. With `lights = Some(n)`: n lights on a 3D grid
/// filling the room, their range shrunk as n grows (`4 m * cbrt(48 / n)`, so a point is in
/// range of about as many lights as with 48) and their intensity with its square (the same
/// brightness): the scene of a light-count study, where light lists pay off.
pub fn light_room(count: Option<u32>) -> Built {
    let mut room = MeshBuilder::new("room", 0);
    // Inward faces, each wall split 8x8 so light falloff has vertices to work with.
    room.cuboid(Vec3::new(-4.0, 0.0, -4.0), Vec3::new(4.0, 3.0, 4.0), true, 8);
    let mut props = MeshBuilder::new("props", 1);
    props.cuboid(Vec3::new(-2.5, 0.0, -2.5), Vec3::new(-1.5, 1.2, -1.5), false, 1);
    props.cuboid(Vec3::new(1.0, 0.0, 1.5), Vec3::new(2.6, 0.8, 2.3), false, 1);
    let mut balls = MeshBuilder::new("balls", 2);
    cube_sphere(&mut balls, Vec3::new(0.0, 0.6, 0.0), 0.6, 6, None);
    cube_sphere(&mut balls, Vec3::new(2.2, 1.3, -2.0), 0.4, 6, None);
    let palette = [
        Vec3::new(1.0, 0.4, 0.3),
        Vec3::new(0.3, 1.0, 0.4),
        Vec3::new(0.3, 0.5, 1.0),
        Vec3::new(1.0, 0.9, 0.6),
    ];
    let lamp = |name: String, position: Vec3, range: f32, intensity: f32, colour: usize| Light {
        name,
        kind: LightKind::Point {
            position,
            range: Some(range),
        },
        color: palette[colour % palette.len()],
        intensity,
        shadowed: false,
    };
    let mut lights = Vec::new();
    match count {
        None => {
            for j in 0..6 {
                for i in 0..8 {
                    let position = Vec3::new(-3.5 + i as f32, 2.7, -3.2 + 1.28 * j as f32);
                    lights.push(lamp(format!("lamp-{j}-{i}"), position, 4.0, 1.5, i + j));
                }
            }
        }
        Some(n) => {
            // The smallest cube grid holding n points, filled x fastest, then z, then y.
            let side = (1..).find(|s: &u32| s * s * s >= n).unwrap_or(1);
            let shrink = libm::cbrtf(48.0 / n as f32);
            let at = |i: u32, lo: f32, hi: f32| lo + (hi - lo) * (i as f32 + 0.5) / side as f32;
            for k in 0..n {
                let (x, z, y) = (k % side, k / side % side, k / (side * side));
                let position = Vec3::new(at(x, -4.0, 4.0), at(y, 0.2, 2.9), at(z, -4.0, 4.0));
                let name = format!("lamp-{k}");
                lights.push(lamp(
                    name,
                    position,
                    4.0 * shrink,
                    1.5 * shrink * shrink,
                    (x + y + z) as usize,
                ));
            }
        }
    }
    Built {
        scene: Scene {
            geometry: Geometry {
                meshes: vec![room.build(), props.build(), balls.build()],
            },
            materials: vec![
                material("plaster", [0.8, 0.78, 0.75, 1.0], None, 4.0, 0.05),
                material("wood", [0.55, 0.4, 0.25, 1.0], None, 16.0, 0.1),
                material("ceramic", [0.9, 0.9, 0.95, 1.0], None, 96.0, 0.6),
            ],
            textures: vec![],
            lights,
            surface_maps: Default::default(),
        },
        orbit: Orbit {
            center: Vec3::new(0.0, 1.5, 0.0),
            target: Vec3::new(0.0, 0.8, 0.0),
            radius: 3.2,
            height: 1.6,
            start_deg: 30.0,
            sweep_deg: 360.0,
        },
    }
}

fn random_unit(rng: &mut SplitMix64) -> Vec3 {
    let z = rng.range(-1.0, 1.0);
    let phi = rng.range(0.0, std::f32::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * libm::cosf(phi), r * libm::sinf(phi), z)
}

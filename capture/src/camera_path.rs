//! Camera paths: where the head is in each frame. An orbit around the scene, a camera of
//! the source file, or a keyframed flythrough read from a small TOML file.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;
use shadetrace_formats::{Aabb, Motion, Pose, Scene};

use crate::error::{Error, Result};

/// Which path to follow, as given on the command line.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPathSpec {
    /// The scene's default orbit (built-in scenes) or one fitted to the scene bounds.
    Orbit,
    /// An interior walk inside the scene bounds at eye height ([`Walk::inside`]).
    Walk,
    /// Camera `n` of the source file (glTF cameras, in node order).
    SourceCamera(usize),
    /// A keyframed flythrough TOML file.
    Flythrough(PathBuf),
}

impl CameraPathSpec {
    /// Parses `orbit`, `camera`, `camera:N` or a path to a `.toml` file.
    pub fn parse(s: &str) -> Result<CameraPathSpec> {
        match s {
            "orbit" => Ok(CameraPathSpec::Orbit),
            "walk" => Ok(CameraPathSpec::Walk),
            "camera" => Ok(CameraPathSpec::SourceCamera(0)),
            _ => {
                if let Some(n) = s.strip_prefix("camera:") {
                    let n = n
                        .parse()
                        .map_err(|_| Error::Options(format!("--path {s}: expected camera:N with N a camera index")))?;
                    Ok(CameraPathSpec::SourceCamera(n))
                } else if s.ends_with(".toml") {
                    Ok(CameraPathSpec::Flythrough(PathBuf::from(s)))
                } else {
                    Err(Error::Options(format!(
                        "--path {s}: expected orbit, walk, camera, camera:N or a flythrough .toml file"
                    )))
                }
            }
        }
    }

    /// Recorded in the trace's capture settings (file name only, for reproducible hashes).
    pub fn describe(&self) -> String {
        match self {
            CameraPathSpec::Orbit => "orbit".into(),
            CameraPathSpec::Walk => "walk".into(),
            CameraPathSpec::SourceCamera(n) => format!("camera:{n}"),
            CameraPathSpec::Flythrough(path) => format!(
                "flythrough:{}",
                path.file_name()
                    .map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
            ),
        }
    }
}

/// A circular path at fixed height around `center`, always looking at `target`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub center: Vec3,
    pub target: Vec3,
    pub radius: f32,
    /// Eye height (world y) of the head.
    pub height: f32,
    /// Angle of frame 0, degrees about +y, 0 = on the +z side of the center.
    pub start_deg: f32,
    /// Angle covered by all frames together; a full turn puts frame N back at frame 0.
    pub sweep_deg: f32,
}

impl Orbit {
    /// An orbit that keeps the whole box in view from outside it.
    pub fn around(bounds: &Aabb) -> Orbit {
        if bounds.is_empty() {
            return Orbit {
                center: Vec3::ZERO,
                target: Vec3::ZERO,
                radius: 3.0,
                height: 1.0,
                start_deg: 0.0,
                sweep_deg: 360.0,
            };
        }
        let center = bounds.center();
        let radius = bounds.radius().max(1e-3);
        Orbit {
            center,
            target: center,
            radius: radius * 1.8,
            height: center.y + radius * 0.5,
            start_deg: 0.0,
            sweep_deg: 360.0,
        }
    }

    pub fn pose(&self, frame: u32, frames: u32) -> Pose {
        let angle = (self.start_deg + self.sweep_deg * frame as f32 / frames.max(1) as f32).to_radians();
        let eye = Vec3::new(
            self.center.x + self.radius * libm::sinf(angle),
            self.height,
            self.center.z + self.radius * libm::cosf(angle),
        );
        Pose::look_at(eye, self.target, Vec3::Y)
    }
}

/// Eye height above the floor of the bounds on a walk (a standing adult).
const EYE_HEIGHT_M: f32 = 1.7;

/// A walk seen from inside, as the papers view their scenes (interiors at eye height, tens
/// to hundreds of pixels per triangle), by a stated rule: the eye 1.7 m above the main
/// floor ([`main_floor`]; the lowest point of the bounds without one), at most 60% of the
/// scene's height above the floor for scenes smaller than a room, on a circle around the
/// centre of the bounds with a radius of a quarter of the smaller horizontal half-extent,
/// looking along the direction of travel, 8.5 degrees down. The frames cover one turn. It
/// stays inside the bounds; whether the centre is open floor is the scene's matter (use a
/// flythrough where it is not).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Walk {
    pub center: Vec3,
    pub radius: f32,
    /// Eye height (world y).
    pub eye_y: f32,
}

impl Walk {
    pub fn inside(bounds: &Aabb, floor_y: Option<f32>) -> Walk {
        if bounds.is_empty() {
            return Walk {
                center: Vec3::ZERO,
                radius: 1.0,
                eye_y: EYE_HEIGHT_M,
            };
        }
        let (min, max) = (bounds.min, bounds.max);
        let size = max - min;
        let floor = floor_y.unwrap_or(min.y).clamp(min.y, max.y);
        Walk {
            center: (min + max) * 0.5,
            radius: 0.25 * 0.5 * size.x.min(size.z),
            eye_y: floor + EYE_HEIGHT_M.min(0.6 * (max.y - floor)),
        }
    }

    pub fn pose(&self, frame: u32, frames: u32) -> Pose {
        let angle = (360.0 * frame as f32 / frames.max(1) as f32).to_radians();
        let (s, c) = (libm::sinf(angle), libm::cosf(angle));
        let eye = Vec3::new(
            self.center.x + self.radius * s,
            self.eye_y,
            self.center.z + self.radius * c,
        );
        // The direction of travel (counter-clockwise seen from above), a metre or a radius
        // ahead, slightly down.
        let ahead = self.radius.max(1.0);
        let forward = Vec3::new(c, 0.0, -s);
        Pose::look_at(eye, eye + forward * ahead - Vec3::Y * (0.15 * ahead), Vec3::Y)
    }
}

/// Height bins of [`main_floor`], metres.
const FLOOR_BIN_M: f32 = 0.25;

/// The height of the main floor: of the static, upward-facing triangles (front face within
/// 25 degrees of +y), the 25 cm height band holding the most area, at its area-weighted mean
/// height. None when the scene has no such triangle. (Roofs face up too: a level whose roofs
/// outweigh its floor needs a flythrough.)
pub fn main_floor(scene: &Scene) -> Option<f32> {
    let mut bands: std::collections::BTreeMap<i64, (f32, f32)> = std::collections::BTreeMap::new();
    for mesh in scene.geometry.meshes.iter().filter(|m| m.motion == Motion::Static) {
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions.get(i as usize).copied());
            let (Some(a), Some(b), Some(c)) = (a, b, c) else {
                continue;
            };
            let cross = (b - a).cross(c - a);
            let area = 0.5 * cross.length();
            if !(area.is_finite() && area > 0.0) {
                continue;
            }
            // Front faces are counter-clockwise: a ceiling faces down and does not count.
            if cross.y / (2.0 * area) < 0.9 {
                continue;
            }
            let y = (a.y + b.y + c.y) / 3.0;
            let band = bands.entry(libm::floorf(y / FLOOR_BIN_M) as i64).or_default();
            band.0 += area;
            band.1 += area * y;
        }
    }
    let (_, &(area, weighted)) = bands.iter().max_by(|x, y| x.1 .0.total_cmp(&y.1 .0))?;
    Some(weighted / area)
}

/// A flythrough file:
///
/// ```toml
/// fov_deg = 90            # optional vertical field of view
/// [[key]]
/// time = 0.0              # seconds
/// position = [0.0, 1.6, 5.0]
/// look_at = [0.0, 1.0, 0.0]
/// [[key]]
/// time = 4.0
/// position = [3.0, 1.6, 0.0]
/// look_at = [0.0, 1.0, 0.0]
/// ```
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Flythrough {
    pub fov_deg: Option<f32>,
    #[serde(rename = "key")]
    pub keys: Vec<Keyframe>,
}

#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    pub time: f32,
    pub position: [f32; 3],
    pub look_at: [f32; 3],
}

impl Flythrough {
    pub fn load(path: &Path) -> Result<Flythrough> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::input(path.display(), e.to_string()))?;
        Flythrough::parse(&text).map_err(|msg| Error::input(path.display(), msg))
    }

    /// Parses and checks a flythrough: at least one key, finite values, increasing times.
    pub fn parse(text: &str) -> Result<Flythrough, String> {
        let fly: Flythrough = toml::from_str(text).map_err(|e| e.message().replace('\n', " "))?;
        if fly.keys.is_empty() {
            return Err("flythrough has no [[key]] entries".into());
        }
        for (i, k) in fly.keys.iter().enumerate() {
            let finite = k.time.is_finite() && k.position.iter().chain(&k.look_at).all(|v| v.is_finite());
            if !finite {
                return Err(format!("key {i} has a non-finite value"));
            }
            if Vec3::from(k.position) == Vec3::from(k.look_at) {
                return Err(format!("key {i} looks at its own position"));
            }
            if i > 0 && k.time <= fly.keys[i - 1].time {
                return Err(format!("key {i} time {} does not increase", k.time));
            }
        }
        if let Some(fov) = fly.fov_deg {
            if !(fov > 0.0 && fov < 180.0) {
                return Err(format!("fov_deg {fov} is outside (0, 180)"));
            }
        }
        Ok(fly)
    }

    pub fn start_time(&self) -> f32 {
        self.keys[0].time
    }

    pub fn duration(&self) -> f32 {
        self.keys[self.keys.len() - 1].time - self.start_time()
    }

    /// Head pose at `time` (clamped to the keys), positions and targets interpolated
    /// linearly between neighbouring keys.
    pub fn pose_at(&self, time: f32) -> Pose {
        let keys = &self.keys;
        let next = keys.partition_point(|k| k.time <= time);
        let (position, look_at) = if next == 0 {
            (Vec3::from(keys[0].position), Vec3::from(keys[0].look_at))
        } else if next == keys.len() {
            let last = keys[keys.len() - 1];
            (Vec3::from(last.position), Vec3::from(last.look_at))
        } else {
            let (a, b) = (keys[next - 1], keys[next]);
            let s = (time - a.time) / (b.time - a.time);
            (
                Vec3::from(a.position).lerp(Vec3::from(b.position), s),
                Vec3::from(a.look_at).lerp(Vec3::from(b.look_at), s),
            )
        };
        let up = if (look_at - position).normalize_or(Vec3::Z).y.abs() > 0.999 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        Pose::look_at(position, look_at, up)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_specs() {
        assert_eq!(CameraPathSpec::parse("orbit").unwrap(), CameraPathSpec::Orbit);
        assert_eq!(CameraPathSpec::parse("walk").unwrap(), CameraPathSpec::Walk);
        assert_eq!(
            CameraPathSpec::parse("camera:2").unwrap(),
            CameraPathSpec::SourceCamera(2)
        );
        assert!(CameraPathSpec::parse("camera:x").is_err());
        assert!(CameraPathSpec::parse("spiral").is_err());
    }

    #[test]
    fn flythrough_interpolates_and_clamps() {
        let fly = Flythrough::parse(
            "[[key]]\ntime = 0.0\nposition = [0.0, 1.0, 4.0]\nlook_at = [0.0, 1.0, 0.0]\n\
             [[key]]\ntime = 2.0\nposition = [4.0, 1.0, 4.0]\nlook_at = [0.0, 1.0, 0.0]\n",
        )
        .unwrap();
        assert_eq!(fly.pose_at(1.0).position, Vec3::new(2.0, 1.0, 4.0));
        assert_eq!(fly.pose_at(-5.0).position, Vec3::new(0.0, 1.0, 4.0));
        assert_eq!(fly.pose_at(9.0).position, Vec3::new(4.0, 1.0, 4.0));
    }

    #[test]
    fn flythrough_rejects_bad_files() {
        assert!(Flythrough::parse("").unwrap_err().contains("key"));
        assert!(Flythrough::parse("[[key]]\ntime = 0.0\nposition = [0.0, 0.0]\nlook_at = [0.0, 1.0, 0.0]\n").is_err());
        let backwards = "[[key]]\ntime = 1.0\nposition = [0.0, 1.0, 4.0]\nlook_at = [0.0, 1.0, 0.0]\n\
                         [[key]]\ntime = 0.5\nposition = [1.0, 1.0, 4.0]\nlook_at = [0.0, 1.0, 0.0]\n";
        assert!(Flythrough::parse(backwards).unwrap_err().contains("increase"));
    }

    #[test]
    fn orbit_looks_at_target() {
        let orbit = Orbit::around(&Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::splat(1.0),
        });
        for f in 0..4 {
            let pose = orbit.pose(f, 4);
            let forward = pose.orientation * Vec3::NEG_Z;
            let to_target = (orbit.target - pose.position).normalize();
            assert!(forward.dot(to_target) > 0.9999);
        }
    }

    #[test]
    fn walk_stays_inside_at_eye_height_looking_ahead() {
        let room = Aabb {
            min: Vec3::new(-5.0, 0.0, -7.0),
            max: Vec3::new(5.0, 4.0, 7.0),
        };
        let walk = Walk::inside(&room, None);
        assert_eq!(walk.eye_y, 1.7);
        let mut previous: Option<Vec3> = None;
        for f in 0..8 {
            let pose = walk.pose(f, 8);
            let p = pose.position;
            assert!(p.cmpgt(room.min).all() && p.cmplt(room.max).all(), "{p}");
            assert!(((p - walk.center) * Vec3::new(1.0, 0.0, 1.0)).length() - 1.25 < 1e-5);
            let forward = pose.orientation * Vec3::NEG_Z;
            assert!(forward.y < 0.0 && forward.y > -0.2, "slightly down: {forward}");
            if let Some(q) = previous {
                // It looks where it goes next.
                assert!(forward.dot((p - q).normalize()) > 0.9);
            }
            previous = Some(p);
        }
        // A tabletop scene 0.7 m high: the eye stays inside it.
        let table = Aabb {
            min: Vec3::new(-1.5, 0.0, -1.5),
            max: Vec3::new(1.5, 0.7, 1.5),
        };
        assert!(Walk::inside(&table, None).eye_y < 0.7);
        // On a raised main floor the eye stands on it.
        assert!((Walk::inside(&room, Some(1.0)).eye_y - 2.7).abs() < 1e-6);
    }

    #[test]
    fn main_floor_is_the_level_band_with_the_most_area() {
        use shadetrace_formats::{Geometry, Mesh};
        let quad = |y: f32, half: f32| Mesh {
            positions: vec![
                Vec3::new(-half, y, -half),
                Vec3::new(half, y, -half),
                Vec3::new(half, y, half),
                Vec3::new(-half, y, half),
            ],
            indices: vec![0, 2, 1, 0, 3, 2],
            ..Mesh::default()
        };
        let wall = Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(9.0, 0.0, 0.0),
                Vec3::new(0.0, 9.0, 0.0),
            ],
            indices: vec![0, 1, 2],
            ..Mesh::default()
        };
        // A pit bottom at -3 m (small), the main floor at 0.5 m (large), a wall.
        let scene = Scene {
            geometry: Geometry {
                meshes: vec![quad(-3.0, 1.0), quad(0.5, 5.0), wall],
            },
            ..Scene::default()
        };
        assert!((main_floor(&scene).unwrap() - 0.5).abs() < 1e-6);
        assert_eq!(main_floor(&Scene::default()), None);
    }
}

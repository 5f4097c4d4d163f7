//! The static transforms (`/tf_static`): read, given as `static_transform_publisher`
//! takes them, and chained from one frame to another.

use super::*;

/// A transform of `/tf_static`: the child frame's origin and axes in the parent frame.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticTransform {
    /// The parent frame (a leading `/` removed).
    pub parent: String,
    /// The child frame.
    pub child: String,
    /// The child's origin in the parent frame, m.
    pub translation: [f64; 3],
    /// The child's axes in the parent frame, as a quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl StaticTransform {
    /// A transform as `static_transform_publisher`'s arguments give it: `x y z yaw pitch
    /// roll parent child` (m, rad; the rotation `R_z(yaw) R_y(pitch) R_x(roll)`) or `x y z
    /// qx qy qz qw parent child`.
    pub fn from_publisher_args(text: &str) -> Result<Self, String> {
        let f: Vec<&str> = text.split_whitespace().collect();
        let n = f.len();
        if n != 8 && n != 9 {
            return Err(format!(
                "`{text}`: give `x y z yaw pitch roll parent child` or `x y z qx qy qz qw \
                 parent child` ({n} fields)"
            ));
        }
        let v: Vec<f64> = f[..n - 2]
            .iter()
            .map(|s| s.parse::<f64>().map_err(|_| format!("`{text}`: `{s}` is not a number")))
            .collect::<Result<_, _>>()?;
        if v.iter().any(|x| !x.is_finite()) {
            return Err(format!("`{text}`: a number is not finite"));
        }
        let rotation = if n == 8 {
            let q = nalgebra::UnitQuaternion::from_euler_angles(v[5], v[4], v[3]);
            [q.i, q.j, q.k, q.w]
        } else {
            let norm = (v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]).sqrt();
            if (norm - 1.0).abs() > 1e-3 {
                return Err(format!("`{text}`: the quaternion's norm is {norm}, not 1"));
            }
            [v[3] / norm, v[4] / norm, v[5] / norm, v[6] / norm]
        };
        Ok(StaticTransform {
            parent: frame_name(f[n - 2]).to_string(),
            child: frame_name(f[n - 1]).to_string(),
            translation: [v[0], v[1], v[2]],
            rotation,
        })
    }
}

/// A frame name as tf compares them: without a leading `/`.
pub(super) fn frame_name(f: &str) -> &str {
    f.strip_prefix('/').unwrap_or(f)
}

/// The topic whose `tf2_msgs/TFMessage` messages are read: the static transforms.
pub const TF_STATIC: &str = "/tf_static";

impl Recording {
    /// Where frame `to` is in frame `from` through the static transforms (chained, either
    /// way along each): its axes `R` (a vector in `to` is `R v` in `from`) and its origin
    /// `t` in `from`, m. `None` when the transforms do not connect them.
    pub fn transform(
        &self,
        from: &str,
        to: &str,
    ) -> Option<(nalgebra::Matrix3<f64>, nalgebra::Vector3<f64>)> {
        use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
        let (from, to) = (frame_name(from), frame_name(to));
        // edges both ways: parent → child as given, child → parent inverted
        let mut edges: Vec<(&str, &str, Matrix3<f64>, Vector3<f64>)> = Vec::new();
        for t in &self.transforms {
            let [x, y, z, w] = t.rotation;
            let r = *UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
                .to_rotation_matrix()
                .matrix();
            let p = Vector3::from(t.translation);
            edges.push((&t.parent, &t.child, r, p));
            edges.push((&t.child, &t.parent, r.transpose(), -(r.transpose() * p)));
        }
        // breadth first from `from`, composing poses
        let mut seen = vec![(from, Matrix3::identity(), Vector3::zeros())];
        let mut k = 0;
        while k < seen.len() {
            let (frame, r, p) = seen[k];
            if frame == to {
                return Some((r, p));
            }
            for (a, b, r2, p2) in &edges {
                if *a == frame && !seen.iter().any(|(f, _, _)| f == b) {
                    seen.push((b, r * r2, p + r * p2));
                }
            }
            k += 1;
        }
        None
    }
}

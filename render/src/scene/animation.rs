//! glTF animations: keyframed node translation, rotation and scale, sampled at a time in seconds.
//!
//! # Manual
//! An animation is a set of channels; each channel drives one property of one node with a
//! sampler (keyframe times in seconds, an f32 scalar accessor, strictly increasing; values,
//! VEC3 f32 for `translation` and `scale`, VEC4 f32 or normalized integers for `rotation`).
//! Sampled at time `t` (a frame shows the scene at `frame / fps` seconds):
//!
//! | interpolation | between keyframes k and k+1, s = (t − t_k) / (t_{k+1} − t_k) |
//! |---|---|
//! | `STEP` | the value of keyframe k |
//! | `LINEAR` | (1 − s)·v_k + s·v_{k+1}; rotations: slerp on the shortest arc (v_{k+1} negated when v_k·v_{k+1} < 0) |
//! | `CUBICSPLINE` | the Hermite spline of glTF 2.0 Appendix C; outputs are (in-tangent, value, out-tangent) triplets and tangents are scaled by Δt = t_{k+1} − t_k; rotations are normalised afterwards |
//!
//! Before the first keyframe a channel holds its first value, after the last its last value.
//! Nodes no channel drives keep their static transform; a driven node starts from its static
//! translation / rotation / scale and the channels replace the properties they target.
//! Everything is evaluated in f64, so a frame is a pure function of (file, animation, time).
//!
//! Refused, with an error naming the animation and channel: morph-target `weights` channels,
//! channels driving a skinned node or a node given by a `matrix` (glTF forbids animating those),
//! two channels driving the same property of one node, and malformed samplers (wrong accessor
//! types or counts, times not strictly increasing, non-finite values, zero quaternions).
use super::SceneError;
use glam::{DMat4, DQuat, DVec3, DVec4};
use gltf::json::animation::{Interpolation as JsonInterpolation, Property};
use gltf::json::validation::Checked;

/// What the coordinator shows and validates about an animation.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationInfo {
    pub name: Option<String>,
    /// The last keyframe time over all channels (0 without channels).
    pub duration_s: f64,
    pub channels: usize,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    Linear,
    CubicSpline,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Translation,
    Rotation,
    Scale,
}

/// One sampler's keyframes. `values` holds one value per time (xyz in a VEC3 track, w = 0), or
/// for `CubicSpline` three per time: in-tangent, value, out-tangent.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    pub interpolation: Interpolation,
    pub times: Vec<f64>,
    pub values: Vec<DVec4>,
}

#[derive(Clone, Debug)]
pub struct Channel {
    pub node: usize,
    pub target: Target,
    pub track: Track,
}

#[derive(Clone, Debug)]
pub struct Animation {
    pub name: Option<String>,
    pub channels: Vec<Channel>,
}

impl Animation {
    pub fn info(&self) -> AnimationInfo {
        let duration_s = self
            .channels
            .iter()
            .filter_map(|c| c.track.times.last())
            .fold(0.0, |a: f64, &b| a.max(b));
        AnimationInfo { name: self.name.clone(), duration_s, channels: self.channels.len() }
    }

    /// The local transforms of the nodes this animation drives, at `time_s`.
    pub fn pose(&self, doc: &gltf::Document, time_s: f64) -> Pose {
        let mut trs: Vec<Option<(DVec3, DQuat, DVec3)>> = vec![None; doc.nodes().len()];
        for c in &self.channels {
            let slot = trs[c.node].get_or_insert_with(|| static_trs(doc, c.node));
            match c.target {
                Target::Translation => slot.0 = c.track.sample(time_s).truncate(),
                Target::Rotation => slot.1 = c.track.sample_rotation(time_s),
                Target::Scale => slot.2 = c.track.sample(time_s).truncate(),
            }
        }
        Pose {
            local: trs
                .into_iter()
                .map(|t| t.map(|(t, r, s)| DMat4::from_scale_rotation_translation(s, r, t)))
                .collect(),
        }
    }
}

/// Local transforms that replace the file's static ones, by node index (none: a still).
#[derive(Clone, Debug, Default)]
pub struct Pose {
    local: Vec<Option<DMat4>>,
}

impl Pose {
    pub fn local(&self, node: usize) -> Option<DMat4> {
        self.local.get(node).copied().flatten()
    }
}

fn static_trs(doc: &gltf::Document, node: usize) -> (DVec3, DQuat, DVec3) {
    let n = doc.nodes().nth(node).expect("channel nodes are checked at parse");
    let (t, r, s) = n.transform().decomposed();
    let r = DQuat::from_array(r.map(f64::from));
    let r = if r.length_squared() > 0.0 { r.normalize() } else { DQuat::IDENTITY };
    (DVec3::from_array(t.map(f64::from)), r, DVec3::from_array(s.map(f64::from)))
}

impl Track {
    /// The (unit, for rotations) value of keyframe `k`.
    fn value(&self, k: usize) -> DVec4 {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            Interpolation::Step | Interpolation::Linear => self.values[k],
        }
    }

    /// Where `t` falls: a keyframe to hold, or a segment (k, s) with s in (0, 1).
    fn locate(&self, t: f64) -> Result<usize, (usize, f64)> {
        let last = self.times.len() - 1;
        if !(t > self.times[0]) {
            return Ok(0); // also NaN: the first value
        }
        if t >= self.times[last] {
            return Ok(last);
        }
        let k = self.times.partition_point(|&x| x <= t) - 1;
        Err((k, (t - self.times[k]) / (self.times[k + 1] - self.times[k])))
    }

    /// A translation or scale (in xyz) at time `t`.
    pub fn sample(&self, t: f64) -> DVec4 {
        match self.locate(t) {
            Ok(k) => self.value(k),
            Err((k, s)) => match self.interpolation {
                Interpolation::Step => self.value(k),
                Interpolation::Linear => self.value(k).lerp(self.value(k + 1), s),
                Interpolation::CubicSpline => self.hermite(k, s),
            },
        }
    }

    /// A unit quaternion at time `t`.
    pub fn sample_rotation(&self, t: f64) -> DQuat {
        let q = match self.locate(t) {
            Ok(k) => self.value(k),
            Err((k, s)) => match self.interpolation {
                Interpolation::Step => self.value(k),
                Interpolation::Linear => slerp(self.value(k), self.value(k + 1), s),
                Interpolation::CubicSpline => self.hermite(k, s),
            },
        };
        let q = DQuat::from_vec4(q);
        if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY }
    }

    /// glTF 2.0 Appendix C: p(s) = (2s³−3s²+1)v_k + Δt(s³−2s²+s)b_k + (−2s³+3s²)v_{k+1} + Δt(s³−s²)a_{k+1},
    /// with b_k the out-tangent of keyframe k and a_{k+1} the in-tangent of keyframe k+1.
    fn hermite(&self, k: usize, s: f64) -> DVec4 {
        let dt = self.times[k + 1] - self.times[k];
        let (s2, s3) = (s * s, s * s * s);
        let (v0, b0) = (self.values[3 * k + 1], self.values[3 * k + 2]);
        let (a1, v1) = (self.values[3 * k + 3], self.values[3 * k + 4]);
        v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
            + b0 * (dt * (s3 - 2.0 * s2 + s))
            + v1 * (-2.0 * s3 + 3.0 * s2)
            + a1 * (dt * (s3 - s2))
    }
}

/// Spherical interpolation of unit quaternions along the shorter of the two arcs.
fn slerp(a: DVec4, b: DVec4, s: f64) -> DVec4 {
    let (b, cos) = if a.dot(b) < 0.0 { (-b, -a.dot(b)) } else { (b, a.dot(b)) };
    if cos > 1.0 - 1e-12 {
        return a.lerp(b, s).normalize(); // (nearly) the same rotation: sin θ would vanish
    }
    let theta = cos.min(1.0).acos();
    (a * ((1.0 - s) * theta).sin() + b * (s * theta).sin()) / theta.sin()
}

/// Every animation of the document, validated.
pub fn parse(doc: &gltf::Document, buffers: &[Vec<u8>]) -> Result<Vec<Animation>, SceneError> {
    doc.animations().map(|a| parse_one(doc, &a, buffers)).collect()
}

fn parse_one(
    doc: &gltf::Document,
    anim: &gltf::Animation,
    buffers: &[Vec<u8>],
) -> Result<Animation, SceneError> {
    let json = &doc.as_json().animations[anim.index()];
    let mut channels: Vec<Channel> = Vec::with_capacity(json.channels.len());
    for (c, (channel, cj)) in anim.channels().zip(&json.channels).enumerate() {
        let at =
            |what: &str| SceneError::new(format!("animation {} channel {c}: {what}", anim.index()));
        let node = cj.target.node.value();
        let Some(n) = doc.nodes().nth(node) else {
            return Err(at(&format!(
                "target node {node} does not exist (the file has {} nodes)",
                doc.nodes().len()
            )));
        };
        let target = match cj.target.path {
            Checked::Valid(Property::Translation) => Target::Translation,
            Checked::Valid(Property::Rotation) => Target::Rotation,
            Checked::Valid(Property::Scale) => Target::Scale,
            Checked::Valid(Property::MorphTargetWeights) => {
                return Err(at("morph-target weights are not supported"));
            }
            Checked::Invalid => {
                return Err(at("target path must be translation, rotation or scale"));
            }
        };
        if n.skin().is_some() {
            return Err(at(&format!("node {node} is skinned; skins are not supported")));
        }
        if matches!(n.transform(), gltf::scene::Transform::Matrix { .. }) {
            return Err(at(&format!(
                "node {node} has a matrix; an animated node must use translation/rotation/scale"
            )));
        }
        if channels.iter().any(|o| o.node == node && o.target == target) {
            return Err(at(&format!(
                "node {node} {target:?} is already driven by another channel of this animation"
            )));
        }
        let sampler = channel.sampler();
        let track = read_track(&channel, sampler.index(), json, target, buffers)
            .map_err(|e| at(&format!("sampler {}: {e}", sampler.index())))?;
        channels.push(Channel { node, target, track });
    }
    Ok(Animation { name: anim.name().map(str::to_owned), channels })
}

fn read_track(
    channel: &gltf::animation::Channel,
    sampler: usize,
    json: &gltf::json::Animation,
    target: Target,
    buffers: &[Vec<u8>],
) -> Result<Track, String> {
    use gltf::accessor::{DataType, Dimensions};
    let interpolation = match json.samplers[sampler].interpolation {
        Checked::Valid(JsonInterpolation::Step) => Interpolation::Step,
        Checked::Valid(JsonInterpolation::Linear) => Interpolation::Linear,
        Checked::Valid(JsonInterpolation::CubicSpline) => Interpolation::CubicSpline,
        Checked::Invalid => return Err("interpolation must be STEP, LINEAR or CUBICSPLINE".into()),
    };
    let (input, output) = (channel.sampler().input(), channel.sampler().output());
    super::accessors::check_accessor(&input, buffers).map_err(|e| format!("input accessor {e}"))?;
    super::accessors::check_accessor(&output, buffers)
        .map_err(|e| format!("output accessor {e}"))?;
    if input.dimensions() != Dimensions::Scalar || input.data_type() != DataType::F32 {
        return Err(format!(
            "input accessor has type {:?} of {:?}; keyframe times must be SCALAR f32",
            input.dimensions(),
            input.data_type()
        ));
    }
    let (want, ints_ok) = match target {
        Target::Translation | Target::Scale => (Dimensions::Vec3, false),
        Target::Rotation => (Dimensions::Vec4, true),
    };
    let int =
        matches!(output.data_type(), DataType::I8 | DataType::U8 | DataType::I16 | DataType::U16);
    if output.dimensions() != want
        || !(output.data_type() == DataType::F32 || (ints_ok && int && output.normalized()))
    {
        return Err(format!(
            "output accessor has type {:?} of {:?}, which glTF does not allow for {target:?}",
            output.dimensions(),
            output.data_type()
        ));
    }
    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
    if output.count() != input.count() * per_key {
        return Err(format!(
            "output count {} should be {} ({} keyframe times{})",
            output.count(),
            input.count() * per_key,
            input.count(),
            if per_key == 3 { " × in-tangent, value, out-tangent" } else { "" }
        ));
    }
    let reader = channel.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
    let times = read_times(reader.read_inputs().ok_or("cannot read the input accessor")?)?;
    let mut values: Vec<DVec4> =
        match reader.read_outputs().ok_or("cannot read the output accessor")? {
            gltf::animation::util::ReadOutputs::Translations(it)
            | gltf::animation::util::ReadOutputs::Scales(it) => {
                it.map(|v| DVec3::from_array(v.map(f64::from)).extend(0.0)).collect()
            }
            gltf::animation::util::ReadOutputs::Rotations(r) => {
                r.into_f32().map(|v| DVec4::from_array(v.map(f64::from))).collect()
            }
            gltf::animation::util::ReadOutputs::MorphTargetWeights(_) => {
                return Err("morph-target weights are not supported".into());
            }
        };
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("output value {k} is not finite"));
    }
    if target == Target::Rotation {
        // Keyframe rotations are unit quaternions (renormalised here); tangents are not.
        for (k, v) in values.iter_mut().enumerate().filter(|(k, _)| per_key == 1 || k % 3 == 1) {
            if !(v.length() > 1e-6) {
                return Err(format!("output value {k} is a zero quaternion, not a rotation"));
            }
            *v = v.normalize();
        }
    }
    Ok(Track { interpolation, times, values })
}

fn read_times(it: impl Iterator<Item = f32>) -> Result<Vec<f64>, String> {
    let mut times: Vec<f64> = Vec::new();
    for (k, t) in it.enumerate() {
        let t = f64::from(t);
        if !t.is_finite() {
            return Err(format!("keyframe time {k} is not finite"));
        }
        // Checked while reading, so a huge accessor of zeros stops at its second element.
        if times.last().is_some_and(|&prev| t <= prev) {
            return Err(format!(
                "keyframe times must increase strictly (time {k} is {t} after {})",
                times[k - 1]
            ));
        }
        times.push(t);
    }
    if times.is_empty() { Err("no keyframes".into()) } else { Ok(times) }
}

/// The animation `selector` names: a name first, then a decimal index; None without a
/// selector means the first animation, or none when the scene has none.
pub fn resolve(
    animations: &[AnimationInfo],
    selector: Option<&str>,
) -> Result<Option<usize>, SceneError> {
    let Some(sel) = selector else { return Ok((!animations.is_empty()).then_some(0)) };
    if let Some(i) = animations.iter().position(|a| a.name.as_deref() == Some(sel)) {
        return Ok(Some(i));
    }
    if let Ok(i) = sel.parse::<usize>()
        && i < animations.len()
    {
        return Ok(Some(i));
    }
    let names: Vec<String> = animations
        .iter()
        .enumerate()
        .map(|(i, a)| a.name.clone().unwrap_or_else(|| format!("{i} (unnamed)")))
        .collect();
    let have = if names.is_empty() {
        "the scene has no animations".to_owned()
    } else {
        format!("the scene has: {}", names.join(", "))
    };
    Err(SceneError::new(format!("no animation named {sel} ({have})")))
}

//! How many triangles a scene instances, known from accessor counts before any vertex is read:
//! the limit a loader enforces, and the size of the mesh it allocates.
use super::SceneError;
use gltf::mesh::Mode;

/// Triangles still allowed; spent per mesh instance from accessor counts, before reading.
pub struct TriangleBudget {
    left: u64,
    limit: u64,
}

impl TriangleBudget {
    pub fn new(limit: u64) -> TriangleBudget {
        TriangleBudget { left: limit, limit }
    }

    pub fn spend(&mut self, mesh: &gltf::Mesh) -> Result<(), SceneError> {
        for prim in mesh.primitives() {
            self.left = self.left.checked_sub(triangles(&prim)).ok_or_else(|| {
                SceneError::new(format!(
                    "mesh {} primitive {}: the scene has more than {} triangles, the most this loader accepts",
                    mesh.index(),
                    prim.index(),
                    self.limit
                ))
            })?;
        }
        Ok(())
    }
}

/// Triangles the scene's node trees instance, counting only primitives whose accessors lie
/// inside their buffers (so a file cannot claim more than it holds, times its instancing). A
/// node reached twice is counted once: the loader refuses such scenes anyway.
pub fn instanced(scene: &gltf::Scene, nodes: usize, buffers: &[Vec<u8>]) -> u64 {
    let mut seen = vec![false; nodes];
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    let mut total = 0u64;
    while let Some(node) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            continue;
        }
        for prim in node.mesh().iter().flat_map(gltf::Mesh::primitives) {
            if super::accessors::check_primitive(&prim, buffers, &|_| String::new()).is_ok() {
                total = total.saturating_add(triangles(&prim));
            }
        }
        stack.extend(node.children());
    }
    total
}

/// The primitive's triangles by its accessor counts.
fn triangles(prim: &gltf::Primitive) -> u64 {
    let corners =
        prim.indices().or_else(|| prim.get(&gltf::Semantic::Positions)).map_or(0, |a| a.count())
            as u64;
    match prim.mode() {
        Mode::Triangles => corners / 3,
        Mode::TriangleStrip | Mode::TriangleFan => corners.saturating_sub(2),
        _ => 0,
    }
}

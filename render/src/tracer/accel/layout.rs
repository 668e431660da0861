//! Where the wide tree's triangles sit in the packet array.
//!
//! A node's hit leaf children hand their triangles to the packet test together (`for_packets`),
//! and a packet holds slots 4k..4k + 4. obvhs lays a node's leaf children out one after another
//! from an arbitrary slot, so a leaf of three triangles often straddles two packets and costs two
//! packet tests. Here every node's triangles start at a multiple of four, and its leaf children
//! (one to three triangles each) are packed first-fit-decreasing so that none straddles: a leaf
//! child costs at most one packet test, and two hit leaf children sharing a packet cost one.
//! Slots left over are padding ([`PAD`]): no node's metadata names them, so no lane of theirs is
//! ever tested.
//!
//! A node whose children would need more than the 24 slots obvhs's metadata can address (its
//! offsets are 5 bits below 24) keeps obvhs's order, from an aligned start.
use obvhs::cwbvh::CwBvh;

/// The primitive index of a padding slot.
pub(super) const PAD: u32 = u32::MAX;

/// Slots a node's leaf children may span (obvhs's leaf offsets and the hit mask's low 24 bits).
const NODE_SLOTS: u32 = 24;

/// Lays `bvh`'s primitive slots out as the module docs say, rewriting each node's
/// `primitive_base_idx` and its leaf children's offsets.
pub(super) fn pack_leaves(bvh: &mut CwBvh) {
    let old = std::mem::take(&mut bvh.primitive_indices);
    let mut slots: Vec<u32> = Vec::with_capacity(old.len() + old.len() / 2);
    for node in &mut bvh.nodes {
        // (child, first old slot, count) of each leaf child.
        let leaves: Vec<(usize, u32, u32)> = (0..8)
            .filter(|&c| node.child_meta[c] != 0 && node.is_leaf(c))
            .map(|c| {
                let (first, count) = node.child_primitives(c);
                (c, first, count)
            })
            .collect();
        slots.resize(slots.len().next_multiple_of(4), PAD);
        let base = slots.len() as u32;
        node.primitive_base_idx = base;
        let offsets = packed(&leaves).unwrap_or_else(|| in_order(&leaves));
        for (&(child, first, count), offset) in leaves.iter().zip(offsets) {
            let at = (base + offset) as usize;
            if slots.len() < at + count as usize {
                slots.resize(at + count as usize, PAD);
            }
            slots[at..at + count as usize]
                .copy_from_slice(&old[first as usize..(first + count) as usize]);
            node.child_meta[child] = (node.child_meta[child] & 0b1110_0000) | offset as u8;
        }
    }
    slots.resize(slots.len().next_multiple_of(4), PAD);
    bvh.primitive_indices = slots;
}

/// Each leaf's offset from the node's (aligned) first slot with no leaf straddling a packet,
/// first-fit-decreasing; None if that needs more than [`NODE_SLOTS`] slots.
fn packed(leaves: &[(usize, u32, u32)]) -> Option<Vec<u32>> {
    let mut order: Vec<usize> = (0..leaves.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(leaves[i].2));
    let mut used: Vec<u32> = Vec::new(); // slots taken in each packet
    let mut offsets = vec![0; leaves.len()];
    for i in order {
        let count = leaves[i].2;
        let packet = match used.iter().position(|&u| u + count <= 4) {
            Some(p) => p,
            None => {
                used.push(0);
                used.len() - 1
            }
        };
        offsets[i] = 4 * packet as u32 + used[packet];
        used[packet] += count;
    }
    (4 * used.len() as u32 <= NODE_SLOTS).then_some(offsets)
}

/// Each leaf's offset with the leaves one after another in child order (obvhs's layout).
fn in_order(leaves: &[(usize, u32, u32)]) -> Vec<u32> {
    leaves
        .iter()
        .scan(0, |next, &(_, _, count)| {
            let at = *next;
            *next += count;
            Some(at)
        })
        .collect()
}

#[cfg(test)]
mod tests;

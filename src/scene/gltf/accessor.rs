//! Reading glTF accessors with every byte range checked.
//!
//! Written here rather than using the gltf crate's typed readers because those read
//! POSITION/NORMAL as f32 regardless of the component type (so KHR_mesh_quantization data
//! comes out wrong) and slice buffers without checking ranges (a malformed file panics).

use gltf::accessor::{DataType, Dimensions};
use rayon::prelude::*;

use crate::util::limits::MAX_ACCESSOR_ELEMENTS as MAX_COUNT;

pub(super) type Buffers<'a> = [std::borrow::Cow<'a, [u8]>];

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn multiplicity(d: Dimensions) -> usize {
    d.multiplicity()
}

/// Decodes one component, applying glTF's normalisation rules for normalised integers.
fn component(bytes: &[u8], t: DataType, normalized: bool) -> f32 {
    match t {
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        DataType::U8 => {
            let v = bytes[0] as f32;
            if normalized { v / 255.0 } else { v }
        }
        DataType::I8 => {
            let v = bytes[0] as i8 as f32;
            if normalized { (v / 127.0).max(-1.0) } else { v }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([bytes[0], bytes[1]]) as f32;
            if normalized { v / 65535.0 } else { v }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([bytes[0], bytes[1]]) as f32;
            if normalized { (v / 32767.0).max(-1.0) } else { v }
        }
        DataType::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f32,
    }
}

fn integer(bytes: &[u8], t: DataType) -> Option<u32> {
    match t {
        DataType::U8 => Some(bytes[0] as u32),
        DataType::U16 => Some(u16::from_le_bytes([bytes[0], bytes[1]]) as u32),
        DataType::U32 => Some(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]])),
        _ => None,
    }
}

/// The bytes of a buffer view, checked against its buffer.
fn view_bytes<'b>(view: &gltf::buffer::View, buffers: &'b Buffers<'_>) -> Result<&'b [u8], String> {
    let b = view.buffer().index();
    let data = buffers.get(b).ok_or_else(|| format!("bufferView {} refers to missing buffer {b}", view.index()))?;
    let end = view.offset().checked_add(view.length()).ok_or("bufferView range overflows")?;
    if end > data.len() {
        return Err(format!(
            "bufferView {} (bytes {}..{end}) runs past the end of buffer {b} ({} bytes)",
            view.index(),
            view.offset(),
            data.len()
        ));
    }
    Ok(&data[view.offset()..end])
}

/// Elements per parallel work item of the accessor decodes.
const DECODE_CHUNK: usize = 1 << 14;

/// A checked view's bytes and the stride of its `elem`-byte elements (after `check_elements`
/// passed for it).
fn elements<'b>(view: &gltf::buffer::View, buffers: &'b Buffers<'_>, elem: usize) -> (&'b [u8], usize) {
    let b = view.buffer().index();
    (&buffers[b][view.offset()..view.offset() + view.length()], view.stride().unwrap_or(elem))
}

/// Checks that `count` elements of `elem` bytes fit in `view` at `offset`, before anything
/// is allocated for them: a count is only believed once the bytes that hold it exist.
fn check_elements(
    what: &str,
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    elem: usize,
    buffers: &Buffers<'_>,
) -> Result<(), String> {
    for_each_element(what, view, offset, count, elem, buffers, None)
}

/// A visitor of one accessor element: its index and its bytes.
type ElementFn<'a> = &'a mut dyn FnMut(usize, &[u8]);

/// Calls `f(i, element_bytes)` for `count` elements of `elem` bytes in `view` at `offset`
/// (only checks the range when `f` is None).
fn for_each_element(
    what: &str,
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    elem: usize,
    buffers: &Buffers<'_>,
    f: Option<ElementFn<'_>>,
) -> Result<(), String> {
    let bytes = view_bytes(view, buffers)?;
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!("{what}: byteStride {stride} is smaller than its {elem}-byte elements"));
    }
    if count == 0 {
        return Ok(());
    }
    let last = (count - 1)
        .checked_mul(stride)
        .and_then(|x| x.checked_add(offset))
        .and_then(|x| x.checked_add(elem))
        .ok_or_else(|| format!("{what}: byte range overflows"))?;
    if last > bytes.len() {
        return Err(format!(
            "{what}: {count} elements of {elem} bytes from offset {offset} need {last} bytes but bufferView {} has {}",
            view.index(),
            bytes.len()
        ));
    }
    if let Some(f) = f {
        for i in 0..count {
            let start = offset + i * stride;
            f(i, &bytes[start..start + elem]);
        }
    }
    Ok(())
}

/// Reads a float-valued accessor of `N` components (any component type, normalised or
/// not, sparse or not). `what` names it in errors, e.g. "accessor 3 (POSITION)".
pub(super) fn read_floats<const N: usize>(
    acc: &gltf::Accessor,
    buffers: &Buffers<'_>,
    what: &str,
) -> Result<Vec<[f32; N]>, String> {
    if multiplicity(acc.dimensions()) != N {
        return Err(format!("{what}: expected {N} components, found {:?}", acc.dimensions()));
    }
    let count = acc.count();
    if count > MAX_COUNT {
        return Err(format!("{what}: {count} elements exceed the limit of {MAX_COUNT}"));
    }
    let t = acc.data_type();
    let cs = component_size(t);
    let normalized = acc.normalized();
    let decode = |bytes: &[u8]| -> [f32; N] { std::array::from_fn(|k| component(&bytes[k * cs..], t, normalized)) };
    // Every range first, then the allocations.
    if let Some(view) = acc.view() {
        check_elements(what, &view, acc.offset(), count, cs * N, buffers)?;
    }
    let sparse = match acc.sparse() {
        Some(sparse) => {
            let n = sparse.count();
            if n > count {
                return Err(format!("{what}: sparse substitution of {n} elements in an accessor of {count}"));
            }
            let it = match sparse.indices().index_type() {
                gltf::accessor::sparse::IndexType::U8 => DataType::U8,
                gltf::accessor::sparse::IndexType::U16 => DataType::U16,
                gltf::accessor::sparse::IndexType::U32 => DataType::U32,
            };
            let (iv, vv) = (sparse.indices().view(), sparse.values().view());
            let indices_what = format!("{what} sparse indices");
            let values_what = format!("{what} sparse values");
            check_elements(&indices_what, &iv, sparse.indices().offset(), n, component_size(it), buffers)?;
            check_elements(&values_what, &vv, sparse.values().offset(), n, cs * N, buffers)?;
            Some((sparse, n, it, iv, vv, indices_what, values_what))
        }
        None => None,
    };
    let mut out = vec![[0.0f32; N]; count];
    if let Some(view) = acc.view() {
        // Ranges checked above; large accessors decode in parallel (a million
        // triangles' vertices), each element alone, so the values are the same.
        let elem = cs * N;
        let (bytes, stride) = elements(&view, buffers, elem);
        let offset = acc.offset();
        let f32_plain = t == DataType::F32;
        out.par_chunks_mut(DECODE_CHUNK).enumerate().for_each(|(c, chunk)| {
            for (k, o) in chunk.iter_mut().enumerate() {
                let start = offset + (c * DECODE_CHUNK + k) * stride;
                let b = &bytes[start..start + elem];
                *o = if f32_plain {
                    std::array::from_fn(|j| f32::from_le_bytes([b[4 * j], b[4 * j + 1], b[4 * j + 2], b[4 * j + 3]]))
                } else {
                    decode(b)
                };
            }
        });
    }
    if let Some((sparse, n, it, iv, vv, indices_what, values_what)) = sparse {
        let mut indices = vec![0usize; n];
        for_each_element(
            &indices_what,
            &iv,
            sparse.indices().offset(),
            n,
            component_size(it),
            buffers,
            Some(&mut |i, b| indices[i] = integer(b, it).unwrap_or(u32::MAX) as usize),
        )?;
        let mut values = vec![[0.0f32; N]; n];
        for_each_element(
            &values_what,
            &vv,
            sparse.values().offset(),
            n,
            cs * N,
            buffers,
            Some(&mut |i, b| values[i] = decode(b)),
        )?;
        for (idx, v) in indices.into_iter().zip(values) {
            let slot = out.get_mut(idx).ok_or_else(|| format!("{what}: sparse index {idx} >= count {count}"))?;
            *slot = v;
        }
    }
    Ok(out)
}

/// Reads an index accessor (unsigned scalar) and checks every index against `vertex_count`.
pub(super) fn read_indices(
    acc: &gltf::Accessor,
    buffers: &Buffers<'_>,
    vertex_count: usize,
    what: &str,
) -> Result<Vec<u32>, String> {
    if acc.dimensions() != Dimensions::Scalar
        || !matches!(acc.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
    {
        return Err(format!(
            "{what}: indices must be unsigned 8/16/32-bit scalars, found {:?} {:?}",
            acc.data_type(),
            acc.dimensions()
        ));
    }
    let values = if acc.sparse().is_none() {
        // Read as integers directly, in parallel (ranges checked first).
        let count = acc.count();
        if count > MAX_COUNT {
            return Err(format!("{what}: {count} elements exceed the limit of {MAX_COUNT}"));
        }
        let t = acc.data_type();
        let cs = component_size(t);
        let mut out = vec![0u32; count];
        if let Some(view) = acc.view() {
            check_elements(what, &view, acc.offset(), count, cs, buffers)?;
            let (bytes, stride) = elements(&view, buffers, cs);
            let offset = acc.offset();
            out.par_chunks_mut(DECODE_CHUNK).enumerate().for_each(|(c, chunk)| {
                for (k, o) in chunk.iter_mut().enumerate() {
                    let start = offset + (c * DECODE_CHUNK + k) * stride;
                    *o = integer(&bytes[start..start + cs], t).unwrap_or(u32::MAX);
                }
            });
        }
        out
    } else {
        read_sparse_indices(acc, buffers, what)?
    };
    if let Some((i, &bad)) = values.iter().enumerate().find(|&(_, &v)| v as usize >= vertex_count) {
        return Err(format!("{what}: index {bad} at position {i} is out of range ({vertex_count} vertices)"));
    }
    Ok(values)
}

/// A sparse index accessor (u8, u16: exact as floats; u32 refused).
fn read_sparse_indices(acc: &gltf::Accessor, buffers: &Buffers<'_>, what: &str) -> Result<Vec<u32>, String> {
    let values = read_floats::<1>(acc, buffers, what).map(|v| v.into_iter().map(|[x]| x as u32).collect::<Vec<_>>())?;
    // f32 holds every u8/u16 exactly; re-read u32 exactly (f32 would round above 2^24).
    let values = if acc.data_type() == DataType::U32 {
        let mut exact = vec![0u32; acc.count()];
        if let Some(view) = acc.view() {
            for_each_element(
                what,
                &view,
                acc.offset(),
                acc.count(),
                4,
                buffers,
                Some(&mut |i, b| exact[i] = u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            )?;
        }
        if acc.sparse().is_some() {
            return Err(format!("{what}: sparse u32 index accessors are not supported"));
        }
        exact
    } else {
        values
    };
    Ok(values)
}

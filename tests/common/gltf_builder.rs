//! Writes small glTF 2.0 documents in code (buffers as base64 data: URIs), so loader tests
//! do not depend on any file.

use base64::Engine;
use serde_json::{Value, json};

/// A glTF document under construction.
#[derive(Default)]
pub struct Gltf {
    bin: Vec<u8>,
    pub accessors: Vec<Value>,
    pub buffer_views: Vec<Value>,
    pub meshes: Vec<Value>,
    pub nodes: Vec<Value>,
    pub materials: Vec<Value>,
    pub textures: Vec<Value>,
    pub images: Vec<Value>,
    pub samplers: Vec<Value>,
    pub cameras: Vec<Value>,
    pub lights: Vec<Value>,
    pub animations: Vec<Value>,
    pub extensions_required: Vec<String>,
    pub extensions_used: Vec<String>,
    pub scene_nodes: Vec<usize>,
}

impl Gltf {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.buffer_views.push(v);
        self.buffer_views.len() - 1
    }

    /// A float accessor of VEC2/VEC3/VEC4 (with min/max for VEC3 positions).
    pub fn floats(&mut self, data: &[f32], components: usize, with_bounds: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34962));
        let ty = match components {
            1 => "SCALAR",
            2 => "VEC2",
            3 => "VEC3",
            _ => "VEC4",
        };
        let mut acc = json!({"bufferView": view, "componentType": 5126, "count": data.len() / components, "type": ty});
        if with_bounds {
            let mut lo = vec![f32::INFINITY; components];
            let mut hi = vec![f32::NEG_INFINITY; components];
            for c in data.chunks(components) {
                for k in 0..components {
                    if c[k].is_finite() {
                        lo[k] = lo[k].min(c[k]);
                        hi[k] = hi[k].max(c[k]);
                    }
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A float SCALAR accessor without a buffer-view target (animation keyframe times and
    /// weights: glTF forbids vertex-buffer targets on them).
    pub fn scalars(&mut self, data: &[f32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        let (lo, hi) = data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), v| (l.min(*v), h.max(*v)));
        self.accessors.push(json!({"bufferView": view, "componentType": 5126, "count": data.len(), "type": "SCALAR", "min": [lo], "max": [hi]}));
        self.accessors.len() - 1
    }

    /// A float VEC3/VEC4 accessor without a buffer-view target (animation outputs).
    pub fn values(&mut self, data: &[f32], components: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        let ty = if components == 3 { "VEC3" } else { "VEC4" };
        self.accessors
            .push(json!({"bufferView": view, "componentType": 5126, "count": data.len() / components, "type": ty}));
        self.accessors.len() - 1
    }

    pub fn indices(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(34963));
        self.accessors.push(json!({"bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    /// An embedded PNG image + texture (nearest filtering), returning the texture index.
    pub fn texture_png(&mut self, png: &[u8]) -> usize {
        let view = self.view(png, None);
        self.images.push(json!({"bufferView": view, "mimeType": "image/png"}));
        self.samplers.push(json!({"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}));
        self.textures.push(json!({"source": self.images.len() - 1, "sampler": self.samplers.len() - 1}));
        self.textures.len() - 1
    }

    /// A mesh with one primitive; returns the mesh index.
    pub fn mesh(&mut self, attributes: Value, indices: Option<usize>, mode: u32, material: Option<usize>) -> usize {
        let mut p = json!({"attributes": attributes, "mode": mode});
        if let Some(i) = indices {
            p["indices"] = json!(i);
        }
        if let Some(m) = material {
            p["material"] = json!(m);
        }
        self.meshes.push(json!({"primitives": [p]}));
        self.meshes.len() - 1
    }

    pub fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    pub fn to_json(&self) -> String {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.bin)
        );
        let mut root = json!({
            "asset": {"version": "2.0", "generator": "cubist tests"},
            "scene": 0,
            "scenes": [{"nodes": self.scene_nodes}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "accessors": self.accessors,
            "bufferViews": self.buffer_views,
            "buffers": [{"byteLength": self.bin.len(), "uri": uri}],
        });
        let obj = root.as_object_mut().unwrap();
        for (k, v) in [
            ("materials", &self.materials),
            ("textures", &self.textures),
            ("images", &self.images),
            ("samplers", &self.samplers),
            ("cameras", &self.cameras),
            ("animations", &self.animations),
        ] {
            if !v.is_empty() {
                obj.insert(k.into(), json!(v));
            }
        }
        if !self.lights.is_empty() {
            obj.insert("extensions".into(), json!({"KHR_lights_punctual": {"lights": self.lights}}));
        }
        let mut used = self.extensions_used.clone();
        if !self.lights.is_empty() && !used.iter().any(|e| e == "KHR_lights_punctual") {
            used.push("KHR_lights_punctual".into());
        }
        if !used.is_empty() {
            obj.insert("extensionsUsed".into(), json!(used));
        }
        if !self.extensions_required.is_empty() {
            obj.insert("extensionsRequired".into(), json!(self.extensions_required));
        }
        serde_json::to_string_pretty(&root).unwrap()
    }

    /// The document as a binary glTF (GLB): a JSON chunk and the buffer as a BIN chunk.
    pub fn to_glb(&self) -> Vec<u8> {
        let mut root: Value = serde_json::from_str(&self.to_json()).unwrap();
        root["buffers"] = json!([{"byteLength": self.bin.len()}]);
        let mut json_chunk = serde_json::to_vec(&root).unwrap();
        while !json_chunk.len().is_multiple_of(4) {
            json_chunk.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json_chunk.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json_chunk.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json_chunk);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }

    pub fn write(&self, dir: &std::path::Path, name: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, self.to_json()).unwrap();
        p
    }
}

/// A unit quad in the XY plane facing +Z, as two indexed triangles.
pub fn quad(g: &mut Gltf, material: Option<usize>) -> usize {
    let pos = g.floats(&[-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0], 3, true);
    let uv = g.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 2, false);
    let idx = g.indices(&[0, 1, 2, 0, 2, 3]);
    g.mesh(json!({"POSITION": pos, "TEXCOORD_0": uv}), Some(idx), 4, material)
}

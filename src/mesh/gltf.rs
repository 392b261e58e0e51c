//! glTF 2.0 meshes (`.gltf` with `.bin` files or data URIs, and binary `.glb`) through
//! the `gltf` crate: the default scene's nodes are walked depth first (children in
//! order), and each node's mesh is placed with the node's world transform. Triangles
//! are numbered in that order: node by node, primitive by primitive, then as the
//! primitive's indices list them (strips and fans unrolled as the specification says;
//! points and lines skipped), so a mesh used by two nodes appears twice.
//!
//! Read: positions, normals (transformed by the inverse transpose), the first set of
//! texture coordinates (`v` flipped to OBJ's convention), and per primitive its
//! material's base colour factor and base colour texture (a file, a data URI or an
//! image in a buffer), with the alpha of a `BLEND` material as opacity. A mirroring
//! transform reverses the winding, as the specification asks. Skins, morph targets,
//! cameras, lights and other material parameters are not read.
//!
//! Errors name the file and what is wrong: the line of a JSON syntax error (in a `.glb`,
//! its byte offset), the JSON path of an invalid reference
//! (`meshes[0].primitives[0].indices`), or the accessor, buffer view and byte range of
//! data that lies outside its buffer.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::{Content, EmbeddedImage, Mesh, MtlMaterial};
use crate::error::{Error, Result};

/// Nodes visited at most while walking a scene (a file whose nodes share children can
/// otherwise ask for exponentially many visits).
const MAX_NODE_VISITS: usize = 1 << 20;

/// Where the JSON starts in a `.glb`: a 12-byte header and an 8-byte chunk header.
const GLB_JSON_START: usize = 20;

/// Load glTF or GLB `bytes` read from `path`.
pub(crate) fn load(path: &Path, bytes: &[u8], content: Content) -> Result<Mesh> {
    let named_glb = path.to_string_lossy().to_ascii_lowercase().trim_end_matches(".gz").ends_with(".glb");
    if named_glb && !bytes.starts_with(b"glTF") {
        let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4)]).escape_debug().to_string();
        return Err(Error::file(path, format!("invalid GLB container, byte 0: it begins with '{head}', not 'glTF'")));
    }
    check_version(path, bytes)?;
    let gltf = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| parse_error(path, bytes, e))?;
    validate(path, &gltf.document)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    check_buffer_files(path, &gltf.document, dir)?;
    let buffers = gltf::import_buffers(&gltf.document, Some(dir), gltf.blob.clone())
        .map_err(|e| buffer_error(path, &gltf.document, e))?;
    let mut reader = Reader {
        path,
        dir,
        buffers: &buffers,
        content,
        mesh: Mesh::default(),
        normals: Vec::new(),
        any_normals: false,
        any_uvs: false,
        uvs: Vec::new(),
        materials: HashMap::new(),
        skipped_primitives: 0,
        visits: 0,
    };
    let doc = &gltf.document;
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        // No scene: every node that is no other node's child.
        None => {
            let children: std::collections::HashSet<usize> =
                doc.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
            doc.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    };
    let mut path_nodes = Vec::new();
    for node in roots {
        reader.node(&node, Mat4::IDENTITY, &mut path_nodes)?;
    }
    reader.finish(doc)
}

/// The mesh being assembled.
struct Reader<'a> {
    path: &'a Path,
    dir: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    content: Content,
    mesh: Mesh,
    /// File normals indexed like the positions (zero where a primitive has none).
    normals: Vec<Vec3>,
    any_normals: bool,
    /// Texture coordinates indexed like the positions (zero where a primitive has none).
    uvs: Vec<Vec2>,
    any_uvs: bool,
    /// glTF material index (`None`: the default material) -> index in `mesh.materials`.
    materials: HashMap<Option<usize>, u32>,
    /// Primitives of points or lines.
    skipped_primitives: usize,
    visits: usize,
}

impl Reader<'_> {
    fn node(&mut self, node: &gltf::Node, parent: Mat4, on_path: &mut Vec<usize>) -> Result<()> {
        if on_path.contains(&node.index()) {
            return Err(Error::file(
                self.path,
                format!("nodes[{}]: a cycle: the node is its own ancestor (through nodes {on_path:?})", node.index()),
            ));
        }
        self.visits += 1;
        if self.visits > MAX_NODE_VISITS {
            return Err(Error::file(
                self.path,
                format!("the scene's nodes are visited more than {MAX_NODE_VISITS} times (nodes shared as children)"),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        if !local.is_finite() {
            return Err(Error::file(self.path, format!("nodes[{}]: its transform is not finite", node.index())));
        }
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                self.primitive(&mesh, &prim, world)?;
            }
        }
        on_path.push(node.index());
        for child in node.children() {
            self.node(&child, world, on_path)?;
        }
        on_path.pop();
        Ok(())
    }

    fn primitive(&mut self, mesh: &gltf::Mesh, prim: &gltf::Primitive, world: Mat4) -> Result<()> {
        let at = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
        if matches!(prim.mode(), Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            self.skipped_primitives += 1;
            return Ok(());
        }
        let err = |msg: String| Error::file(self.path, format!("{at}: {msg}"));
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            return Err(err("no POSITION attribute".into()));
        };
        check_accessor(&pos_acc, "POSITION", &[(Dimensions::Vec3, DataType::F32, 12)], self.buffers).map_err(&err)?;
        let buffers = self.buffers;
        let r = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let positions: Vec<Vec3> =
            r.read_positions().ok_or_else(|| err("POSITION cannot be read".into()))?.map(Vec3::from).collect();
        if let Some((k, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(err(format!("POSITION (accessors[{}]) element {k} is not finite {p}", pos_acc.index())));
        }
        let n = positions.len();
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                check_accessor(
                    &acc,
                    "indices",
                    &[
                        (Dimensions::Scalar, DataType::U8, 1),
                        (Dimensions::Scalar, DataType::U16, 2),
                        (Dimensions::Scalar, DataType::U32, 4),
                    ],
                    self.buffers,
                )
                .map_err(&err)?;
                let idx: Vec<u32> =
                    r.read_indices().ok_or_else(|| err("the indices cannot be read".into()))?.into_u32().collect();
                if let Some((k, &i)) = idx.iter().enumerate().find(|&(_, &i)| i as usize >= n) {
                    return Err(err(format!(
                        "index {k} (accessors[{}]) is {i}, out of range: the primitive has {n} vertices",
                        acc.index()
                    )));
                }
                idx
            }
            None => (0..n as u32).collect(),
        };
        let tris = triangles(prim.mode(), &indices);
        if self.mesh.indices.len() + tris.len() > crate::limits::MAX_PRIMITIVES {
            return Err(Error::file(
                self.path,
                format!("more than {} triangles, the limit of primitives", crate::limits::MAX_PRIMITIVES),
            ));
        }
        let base = self.mesh.positions.len() as u32;
        let mirror = world.determinant() < 0.0;
        for t in &tris {
            let t = if mirror { [t[0], t[2], t[1]] } else { *t };
            self.mesh.indices.push(t.map(|i| base + i));
        }
        self.mesh.positions.extend(positions.iter().map(|&p| world.transform_point3(p)));
        if self.content == Content::Geometry {
            self.mesh.face_material.extend(std::iter::repeat_n(None, tris.len()));
            return Ok(());
        }
        // Normals: the inverse transpose of the world transform (a singular one leaves them
        // to be computed from the faces).
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let file_normals = match prim.get(&gltf::Semantic::Normals) {
            Some(acc) => {
                check_accessor(&acc, "NORMAL", &[(Dimensions::Vec3, DataType::F32, 12)], self.buffers).map_err(&err)?;
                let v: Vec<Vec3> =
                    r.read_normals().ok_or_else(|| err("NORMAL cannot be read".into()))?.map(Vec3::from).collect();
                (v.len() == n).then_some(v)
            }
            None => None,
        };
        match file_normals {
            Some(v) if normal_matrix.is_finite() => {
                self.any_normals = true;
                self.normals.extend(v.into_iter().map(|v| (normal_matrix * v).normalize_or_zero()));
            }
            _ => self.normals.extend(std::iter::repeat_n(Vec3::ZERO, n)),
        }
        let uvs = match prim.get(&gltf::Semantic::TexCoords(0)) {
            Some(acc) => {
                check_accessor(
                    &acc,
                    "TEXCOORD_0",
                    &[
                        (Dimensions::Vec2, DataType::F32, 8),
                        (Dimensions::Vec2, DataType::U8, 2),
                        (Dimensions::Vec2, DataType::U16, 4),
                    ],
                    self.buffers,
                )
                .map_err(&err)?;
                let v: Vec<Vec2> = r
                    .read_tex_coords(0)
                    .ok_or_else(|| err("TEXCOORD_0 cannot be read".into()))?
                    .into_f32()
                    .map(|[u, v]| Vec2::new(u, 1.0 - v))
                    .collect();
                (v.len() == n).then_some(v)
            }
            None => None,
        };
        match uvs {
            Some(v) => {
                self.any_uvs = true;
                self.warn_wrap(&prim.material(), &v);
                self.uvs.extend(v);
            }
            None => self.uvs.extend(std::iter::repeat_n(Vec2::ZERO, n)),
        }
        let material = self.material(&prim.material())?;
        self.mesh.face_material.extend(std::iter::repeat_n(Some(material), tris.len()));
        Ok(())
    }

    /// rtdiff wraps a texture the same way along u and v (Mitsuba's `bitmap` does too); a glTF
    /// sampler may wrap S and T differently. Say so (once per material) where a textured
    /// primitive's coordinates leave [0, 1], where the difference shows; S's mode is used.
    fn warn_wrap(&mut self, m: &gltf::Material, uvs: &[Vec2]) {
        let Some(info) = m.pbr_metallic_roughness().base_color_texture() else { return };
        let s = info.texture().sampler();
        if wrap_mode(s.wrap_s()) == wrap_mode(s.wrap_t()) {
            return;
        }
        let outside = uvs.iter().any(|t| t.x < 0.0 || t.x > 1.0 || t.y < 0.0 || t.y > 1.0);
        let name = m.name().map_or_else(|| format!("materials[{}]", m.index().unwrap_or(0)), str::to_string);
        let warning = format!(
            "{}: material '{name}': texture coordinates outside [0, 1] with wrap modes {:?} (S) and {:?} (T); rtdiff \
             wraps both as {}",
            self.path.display(),
            s.wrap_s(),
            s.wrap_t(),
            wrap_mode(s.wrap_s()).name()
        );
        if outside && !self.mesh.warnings.contains(&warning) {
            self.mesh.warnings.push(warning);
        }
    }

    /// The index in `mesh.materials` of glTF material `m`, added on first use.
    fn material(&mut self, m: &gltf::Material) -> Result<u32> {
        if let Some(&i) = self.materials.get(&m.index()) {
            return Ok(i);
        }
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        let name = match (m.name(), m.index()) {
            (Some(n), _) => n.to_string(),
            (None, Some(i)) => format!("materials[{i}]"),
            (None, None) => "default".to_string(),
        };
        let mut out = MtlMaterial {
            name,
            kd: Some(Vec3::new(r, g, b)),
            opacity: (m.alpha_mode() == gltf::material::AlphaMode::Blend).then_some(a),
            ..Default::default()
        };
        if let Some(info) = pbr.base_color_texture() {
            out.map_kd_wrap = wrap_mode(info.texture().sampler().wrap_s());
            if info.tex_coord() != 0 {
                self.mesh.warnings.push(format!(
                    "{}: material '{}': the base colour texture uses TEXCOORD_{}; rtdiff reads TEXCOORD_0 only",
                    self.path.display(),
                    out.name,
                    info.tex_coord()
                ));
            }
            let image = info.texture().source();
            let label = format!("{}#images[{}]", self.path.display(), image.index());
            match image.source() {
                gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                    let data = uri.split_once(',').map(|(_, d)| d).unwrap_or("");
                    let bytes = base64::decode(data).map_err(|e| {
                        Error::file(self.path, format!("images[{}]: bad base64 data URI: {e}", image.index()))
                    })?;
                    out.map_kd_embedded = Some(EmbeddedImage { name: label, bytes: Arc::new(bytes) });
                }
                gltf::image::Source::Uri { uri, .. } => {
                    let file = urlencoding::decode(uri).map(|c| c.into_owned()).unwrap_or_else(|_| uri.to_string());
                    out.map_kd = Some(self.dir.join(file));
                }
                gltf::image::Source::View { view, .. } => {
                    let data = &self.buffers[view.buffer().index()].0;
                    let bytes =
                        data.get(view.offset()..view.offset().saturating_add(view.length())).ok_or_else(|| {
                            Error::file(
                                self.path,
                                format!(
                                    "images[{}]: bufferViews[{}] (bytes {}..{}) lies outside buffers[{}] of {} bytes",
                                    image.index(),
                                    view.index(),
                                    view.offset(),
                                    view.offset().saturating_add(view.length()),
                                    view.buffer().index(),
                                    data.len()
                                ),
                            )
                        })?;
                    out.map_kd_embedded = Some(EmbeddedImage { name: label, bytes: Arc::new(bytes.to_vec()) });
                }
            }
            // glTF multiplies the texture by the factor; rtdiff's texture replaces kd.
            out.kd_texture_factor = Some(Vec3::new(r, g, b));
        }
        self.mesh.materials.push(out);
        let i = self.mesh.materials.len() as u32 - 1;
        self.materials.insert(m.index(), i);
        Ok(i)
    }

    fn finish(mut self, doc: &gltf::Document) -> Result<Mesh> {
        if self.mesh.indices.is_empty() {
            let meshes = doc.meshes().count();
            let why = if self.skipped_primitives > 0 {
                format!("no triangles: its {} primitives are points or lines", self.skipped_primitives)
            } else if meshes == 0 {
                "no triangles: the file has no meshes".to_string()
            } else {
                format!("no triangles: none of its {meshes} meshes is placed by a node of the scene")
            };
            return Err(Error::file(self.path, why));
        }
        if self.skipped_primitives > 0 {
            self.mesh.warnings.push(format!(
                "{}: {} primitives of points or lines skipped",
                self.path.display(),
                self.skipped_primitives
            ));
        }
        if self.any_uvs {
            self.mesh.uvs = Some(std::mem::take(&mut self.uvs));
        }
        let normals = self.any_normals.then(|| std::mem::take(&mut self.normals));
        let path = self.path;
        self.mesh.finish(path, normals)?;
        Ok(self.mesh)
    }
}

/// Triangles of a primitive of `mode` over `indices` (glTF 2.0, 3.7.2.1).
fn triangles(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    let n = indices.len();
    match mode {
        Mode::Triangles => indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => {
            (0..n.saturating_sub(2)).map(|i| [indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]]).collect()
        }
        Mode::TriangleFan => (1..n.saturating_sub(1)).map(|i| [indices[i], indices[i + 1], indices[0]]).collect(),
        _ => Vec::new(),
    }
}

/// Check that accessor `acc` (read as `what`) has one of the layouts `allowed`
/// (dimensions, component type, bytes per element) and that every element it reads
/// lies inside its buffer view and buffer (the crate would otherwise read nothing, or
/// overflow computing the range).
fn check_accessor(
    acc: &gltf::Accessor,
    what: &str,
    allowed: &[(Dimensions, DataType, usize)],
    buffers: &[gltf::buffer::Data],
) -> std::result::Result<(), String> {
    let name = format!("{what} (accessors[{}])", acc.index());
    let Some(&(_, _, elem)) = allowed.iter().find(|(d, t, _)| *d == acc.dimensions() && *t == acc.data_type()) else {
        let want: Vec<String> = allowed.iter().map(|(d, t, _)| format!("{d:?} of {t:?}")).collect();
        return Err(format!(
            "{name} is {:?} of {:?}; expected {}",
            acc.dimensions(),
            acc.data_type(),
            want.join(" or ")
        ));
    };
    if acc.count() == 0 {
        return Err(format!("{name} has count 0"));
    }
    if let Some(view) = acc.view() {
        check_range(&name, &view, acc.offset(), acc.count(), elem, buffers)?;
    }
    if let Some(s) = acc.sparse() {
        if s.count() == 0 {
            return Err(format!("{name}: its sparse part has count 0"));
        }
        let idx = s.indices();
        let size = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        check_range(&format!("{name} sparse indices"), &idx.view(), idx.offset(), s.count(), size, buffers)?;
        let values = s.values();
        check_range(&format!("{name} sparse values"), &values.view(), values.offset(), s.count(), elem, buffers)?;
    }
    Ok(())
}

fn check_range(
    name: &str,
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    elem: usize,
    buffers: &[gltf::buffer::Data],
) -> std::result::Result<(), String> {
    let stride = view.stride().unwrap_or(elem);
    let end = stride.checked_mul(count - 1).and_then(|x| x.checked_add(offset)).and_then(|x| x.checked_add(elem));
    let buf_len = buffers.get(view.buffer().index()).map_or(0, |b| b.len());
    let view_end = view.offset().checked_add(view.length());
    let fits = matches!((end, view_end), (Some(e), Some(v)) if e <= view.length() && v <= buf_len);
    if fits {
        return Ok(());
    }
    Err(format!(
        "{name}: {count} elements of {elem} bytes (stride {stride}) from byte {offset} of bufferViews[{}] need {} bytes; \
         the view has {} (bytes {}..{} of buffers[{}], which has {buf_len})",
        view.index(),
        end.map_or_else(|| "more than 2^64".to_string(), |e| e.to_string()),
        view.length(),
        view.offset(),
        view.offset().saturating_add(view.length()),
        view.buffer().index(),
    ))
}

/// A buffer named by a file URI must be a regular file of at most the mesh size limit:
/// checked before the crate reads it (`/dev/zero` would never end).
fn check_buffer_files(path: &Path, doc: &gltf::Document, dir: &Path) -> Result<()> {
    for b in doc.buffers() {
        let gltf::buffer::Source::Uri(uri) = b.source() else { continue };
        if uri.starts_with("data:") {
            continue;
        }
        let file: PathBuf = match uri.strip_prefix("file://") {
            Some(p) => PathBuf::from(p),
            None if uri.contains("://") => {
                return Err(Error::file(
                    path,
                    format!("buffers[{}]: '{uri}': only files and data URIs can be read", b.index()),
                ));
            }
            None => dir.join(urlencoding::decode(uri).map(|c| c.into_owned()).unwrap_or_else(|_| uri.to_string())),
        };
        let meta = std::fs::metadata(&file).map_err(|e| {
            let why = if e.kind() == std::io::ErrorKind::NotFound { "not found".to_string() } else { e.to_string() };
            Error::file(path, format!("buffers[{}]: '{uri}' ({}): {why}", b.index(), file.display()))
        })?;
        if !meta.is_file() || meta.len() > crate::limits::MAX_MESH_FILE_BYTES {
            return Err(Error::file(
                path,
                format!(
                    "buffers[{}]: '{uri}' is not a regular file of at most {} bytes",
                    b.index(),
                    crate::limits::MAX_MESH_FILE_BYTES
                ),
            ));
        }
    }
    Ok(())
}

fn buffer_error(path: &Path, doc: &gltf::Document, e: gltf::Error) -> Error {
    match e {
        gltf::Error::BufferLength { buffer, expected, actual } => {
            Error::file(path, format!("buffers[{buffer}]: byteLength is {expected} but the data has {actual} bytes"))
        }
        gltf::Error::MissingBlob => {
            Error::file(path, "a buffer refers to the GLB's binary chunk, which the file lacks")
        }
        other => {
            let n = doc.buffers().count();
            Error::file(path, format!("cannot read the {n} buffers: {other}"))
        }
    }
}

/// glTF 1.0 files (a GLB of version 1, or `asset.version` "1.x") are named as such: their
/// layout differs from 2.0's, and the parser's complaint would not say so.
fn check_version(path: &Path, bytes: &[u8]) -> Result<()> {
    let version = if bytes.starts_with(b"glTF") {
        let v = bytes.get(4..8).map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        (v != 2).then(|| format!("GLB version {v} (byte 4)"))
    } else {
        serde_json::from_slice::<serde_json::Value>(bytes).ok().and_then(|j| {
            let v = j.get("asset")?.get("version")?.as_str()?.to_string();
            (!v.starts_with("2.")).then(|| format!("asset.version \"{v}\""))
        })
    };
    match version {
        Some(v) => Err(Error::file(path, format!("{v}: rtdiff reads glTF 2.0 only"))),
        None => Ok(()),
    }
}

/// Extensions that replace the geometry's accessors with compressed data.
const COMPRESSION: &[&str] = &["KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_mesh_quantization"];

/// The crate's checks (every index refers to something that exists, required
/// extensions are known), less one rtdiff does not need: POSITION's `min` and `max`,
/// which the specification requires but many exporters leave out (bounds are computed
/// from the vertices).
fn validate(path: &Path, doc: &gltf::Document) -> Result<()> {
    use gltf::json::validation::{Error as V, Validate};
    if let Some(ext) = doc.extensions_used().find(|e| COMPRESSION.contains(e)) {
        return Err(Error::file(path, format!("the geometry is compressed with {ext}, which rtdiff does not read")));
    }
    let root = doc.as_json();
    // What the crates index without checking (a panic otherwise): POSITION's accessor in their
    // own validation, an image's source when it has neither URI nor buffer view, or a view without
    // a MIME type.
    for (i, m) in root.meshes.iter().enumerate() {
        for (j, p) in m.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(a) = p.attributes.get(&position)
                && a.value() >= root.accessors.len()
            {
                return Err(Error::file(
                    path,
                    format!(
                        "meshes[{i}].primitives[{j}].attributes.POSITION: accessor {} does not exist (the file has {})",
                        a.value(),
                        root.accessors.len()
                    ),
                ));
            }
        }
    }
    for (i, img) in root.images.iter().enumerate() {
        let why = match (&img.buffer_view, &img.uri, &img.mime_type) {
            (None, None, _) => "neither a uri nor a bufferView",
            (Some(_), _, None) => "a bufferView but no mimeType",
            _ => continue,
        };
        return Err(Error::file(path, format!("images[{i}]: {why}")));
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |p, e| {
        let p = p().to_string();
        if !(e == V::Missing && (p.ends_with(".min") || p.ends_with(".max"))) {
            errors.push((p, e));
        }
    });
    if errors.is_empty() {
        return Ok(());
    }
    let shown: Vec<String> = errors.iter().take(3).map(|(p, e)| format!("{p}: {e}")).collect();
    let more = if errors.len() > 3 { format!(" (and {} more)", errors.len() - 3) } else { String::new() };
    Err(Error::file(path, format!("invalid glTF: {}{more}", shown.join("; "))))
}

/// The error for a file the crate cannot parse.
fn parse_error(path: &Path, bytes: &[u8], e: gltf::Error) -> Error {
    let glb = bytes.starts_with(b"glTF");
    match e {
        gltf::Error::Deserialize(j) if glb => {
            // serde gives the line and column inside the JSON chunk: turn them into a byte offset.
            let json = &bytes[GLB_JSON_START.min(bytes.len())..];
            let mut offset = 0;
            for (i, line) in json.split(|&b| b == b'\n').enumerate() {
                if i + 1 == j.line() {
                    offset += j.column().saturating_sub(1).min(line.len());
                    break;
                }
                offset += line.len() + 1;
            }
            Error::file(path, format!("GLB JSON chunk, byte {}: {}", GLB_JSON_START + offset, strip_position(&j)))
        }
        gltf::Error::Deserialize(j) if j.line() > 0 => Error::at(path, j.line(), strip_position(&j)),
        gltf::Error::Deserialize(j) => Error::file(path, format!("invalid glTF JSON: {j}")),
        gltf::Error::Binary(b) => {
            let at = match b {
                gltf::binary::Error::Magic(_) => "byte 0",
                gltf::binary::Error::Version(_) => "byte 4",
                gltf::binary::Error::Length { .. } => "byte 8",
                _ => "byte 12",
            };
            Error::file(path, format!("invalid GLB container, {at}: {b} ({b:?})"))
        }
        other => Error::file(path, format!("cannot read glTF: {other}")),
    }
}

/// serde's message without its " at line L column C" (the caller says where).
fn strip_position(e: &serde_json::Error) -> String {
    let s = e.to_string();
    match s.rfind(" at line ") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// rtdiff's wrap mode for a glTF sampler's (REPEAT, the glTF default, MIRRORED_REPEAT, CLAMP_TO_EDGE).
fn wrap_mode(w: gltf::texture::WrappingMode) -> crate::texture::WrapMode {
    use crate::texture::WrapMode;
    use gltf::texture::WrappingMode;
    match w {
        WrappingMode::Repeat => WrapMode::Repeat,
        WrappingMode::MirroredRepeat => WrapMode::Mirror,
        WrappingMode::ClampToEdge => WrapMode::Clamp,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_unroll_as_the_specification_says() {
        let idx = [0, 1, 2, 3, 4];
        assert_eq!(triangles(Mode::TriangleStrip, &idx), vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
        assert_eq!(triangles(Mode::TriangleFan, &idx), vec![[1, 2, 0], [2, 3, 0], [3, 4, 0]]);
        assert_eq!(triangles(Mode::Triangles, &idx), vec![[0, 1, 2]]);
        assert!(triangles(Mode::TriangleStrip, &[0, 1]).is_empty());
    }
}

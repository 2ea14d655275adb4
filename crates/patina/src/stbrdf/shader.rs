//! Shader source that evaluates a material at time t from its coefficient
//! textures, for engines (as the paper's Unity shader): one texture per
//! parameter and coefficient (`{Name}-{i}.exr`, bound in that order), and
//! Horner's rule per parameter. WGSL and GLSL.

use super::material::{Material, Param};

/// The identifier for a parameter name (lower case, letters and digits).
fn ident(name: &str) -> String {
    let s: String = name.chars().filter(|c| c.is_ascii_alphanumeric()).collect::<String>().to_lowercase();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        format!("p{s}")
    } else {
        s
    }
}

/// `struct Material {` and one field per parameter (`field(type, name)`).
fn structure(material: &Material, ty: impl Fn(&Param) -> String, field: impl Fn(&str, &str) -> String) -> String {
    let mut s = String::from("\nstruct Material {\n");
    for p in &material.params {
        s += &field(&ty(p), &ident(&p.name));
        s.push('\n');
    }
    s
}

/// Horner's rule per parameter: `{out}.{name} = sample(name, d)`, then
/// `{out}.{name} = {out}.{name} * t + sample(name, k)` down to k = 0.
fn horner(material: &Material, out: &str, sample: impl Fn(&str, usize) -> String) -> String {
    let m = material.degree + 1;
    let mut s = String::new();
    for p in &material.params {
        let id = ident(&p.name);
        let swizzle = match p.channels {
            1 => ".r",
            2 => ".rg",
            3 => ".rgb",
            _ => "",
        };
        s += &format!("    {out}.{id} = {}{swizzle};\n", sample(&id, m - 1));
        for k in (0..m - 1).rev() {
            s += &format!("    {out}.{id} = {out}.{id} * t + {}{swizzle};\n", sample(&id, k));
        }
    }
    s
}

/// WGSL: bindings in group 0 (a sampler at 0, then the coefficient
/// textures), a struct with one field per parameter, and
/// `evaluate_material(uv, t)`.
pub fn wgsl(material: &Material) -> String {
    let m = material.degree + 1;
    let mut s = format!(
        "// patina: spatio-temporal material, degree {}, evaluated at t in [0, 1].\n// Textures: {{Name}}-{{i}}.exr, coefficient i of t^i.\n\n@group(0) @binding(0) var material_sampler: sampler;\n",
        material.degree
    );
    let mut binding = 1;
    for p in &material.params {
        for k in 0..m {
            s += &format!("@group(0) @binding({binding}) var {}_{k}: texture_2d<f32>; // {}-{k}.exr\n", ident(&p.name), p.name);
            binding += 1;
        }
    }
    s += &structure(
        material,
        |p| if p.channels == 1 { "f32".into() } else { format!("vec{}<f32>", p.channels.min(4)) },
        |ty, id| format!("    {id}: {ty},"),
    );
    s += "}\n\nfn evaluate_material(uv: vec2<f32>, t: f32) -> Material {\n    var out: Material;\n";
    s += &horner(material, "out", |id, k| format!("textureSampleLevel({id}_{k}, material_sampler, uv, 0.0)"));
    s += "    return out;\n}\n";
    s
}

/// GLSL (450): `uniform sampler2D {name}_{i}` per coefficient, a struct
/// and `evaluateMaterial(uv, t)`.
pub fn glsl(material: &Material) -> String {
    let m = material.degree + 1;
    let mut s = format!(
        "// patina: spatio-temporal material, degree {}, evaluated at t in [0, 1].\n// Textures: {{Name}}-{{i}}.exr, coefficient i of t^i.\n#version 450\n\n",
        material.degree
    );
    for p in &material.params {
        for k in 0..m {
            s += &format!("uniform sampler2D {}_{k}; // {}-{k}.exr\n", ident(&p.name), p.name);
        }
    }
    s += &structure(
        material,
        |p| if p.channels == 1 { "float".into() } else { format!("vec{}", p.channels.min(4)) },
        |ty, id| format!("    {ty} {id};"),
    );
    s += "};\n\nMaterial evaluateMaterial(vec2 uv, float t) {\n    Material m;\n";
    s += &horner(material, "m", |id, k| format!("texture({id}_{k}, uv)"));
    s += "    return m;\n}\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stbrdf::procedural::drying_wood_params;

    #[test]
    fn shaders_bind_every_coefficient_and_apply_horner_per_parameter() {
        let coef = crate::Image::new(4, 4, 7 * 4);
        let m = Material::new(3, drying_wood_params(), coef).unwrap();
        let w = wgsl(&m);
        assert_eq!(w.matches("texture_2d<f32>").count(), 12);
        assert!(w.contains("out.roughness = out.roughness * t + textureSampleLevel(roughness_0"));
        assert!(w.contains("diffuse: vec3<f32>") && w.contains("roughness: f32"));
        let g = glsl(&m);
        assert_eq!(g.matches("uniform sampler2D").count(), 12);
        assert!(g.contains("m.diffuse = texture(diffuse_3, uv).rgb;"));
        assert_eq!(g.matches(" * t + ").count(), 9, "three Horner steps for each of three parameters");
    }
}

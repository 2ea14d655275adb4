//! Shader source that evaluates a material at time t from its coefficient
//! textures, for engines (as the paper's Unity shader): one texture per
//! parameter and coefficient (`{Name}-{i}.exr`, bound in that order), and
//! Horner's rule per parameter. WGSL, GLSL (450, explicit bindings), HLSL
//! and a Unity ShaderLab surface shader built on the HLSL.
//!
//! The coefficient textures are EXRs and must be sampled as linear data
//! (no sRGB decoding). For a material whose colours are sRGB-encoded
//! ([`Encoding::Srgb`], fitted to 8-bit photos) the Unity shader decodes
//! the evaluated Diffuse and Specular to linear before lighting.

use super::material::{Encoding, Material, Param};

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

/// One line per parameter and coefficient, in binding order:
/// `line(n, ident, name, k)` with n counting from 0.
fn per_texture(material: &Material, line: impl Fn(usize, &str, &str, usize) -> String) -> String {
    let m = material.degree + 1;
    let mut s = String::new();
    for (i, p) in material.params.iter().enumerate() {
        for k in 0..m {
            s += &line(i * m + k, &ident(&p.name), &p.name, k);
        }
    }
    s
}

/// WGSL: bindings in group 0 (a sampler at 0, then the coefficient
/// textures), a struct with one field per parameter, and
/// `evaluate_material(uv, t)`.
pub fn wgsl(material: &Material) -> String {
    let mut s = format!(
        "// patina: spatio-temporal material, degree {}, evaluated at t in [0, 1].\n// Textures: {{Name}}-{{i}}.exr, coefficient i of t^i.\n\n@group(0) @binding(0) var material_sampler: sampler;\n",
        material.degree
    );
    s += &per_texture(material, |n, id, name, k| {
        format!("@group(0) @binding({}) var {id}_{k}: texture_2d<f32>; // {name}-{k}.exr\n", n + 1)
    });
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

/// GLSL (450): `layout(binding = n) uniform sampler2D {name}_{i}` per
/// coefficient (in order from 0), a struct and `evaluateMaterial(uv, t)`.
pub fn glsl(material: &Material) -> String {
    let mut s = format!(
        "// patina: spatio-temporal material, degree {}, evaluated at t in [0, 1].\n// Textures: {{Name}}-{{i}}.exr, coefficient i of t^i.\n#version 450\n\n",
        material.degree
    );
    s += &per_texture(material, |n, id, name, k| format!("layout(binding = {n}) uniform sampler2D {id}_{k}; // {name}-{k}.exr\n"));
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

/// HLSL (Shader Model 4+): `Texture2D {name}_{i}` with its
/// `SamplerState sampler_{name}_{i}` (Unity's naming), a struct and
/// `EvaluateMaterial(uv, t)`.
pub fn hlsl(material: &Material) -> String {
    let mut s = format!(
        "// patina: spatio-temporal material, degree {}, evaluated at t in [0, 1].\n// Textures: {{Name}}-{{i}}.exr, coefficient i of t^i, sampled as linear data.\n\n",
        material.degree
    );
    s += &per_texture(material, |_, id, name, k| format!("Texture2D {id}_{k}; SamplerState sampler_{id}_{k}; // {name}-{k}.exr\n"));
    s += &structure(
        material,
        |p| if p.channels == 1 { "float".into() } else { format!("float{}", p.channels.min(4)) },
        |ty, id| format!("    {ty} {id};"),
    );
    s += "};\n\nMaterial EvaluateMaterial(float2 uv, float t) {\n    Material m;\n";
    s += &horner(material, "m", |id, k| format!("{id}_{k}.SampleLevel(sampler_{id}_{k}, uv, 0)"));
    s += "    return m;\n}\n";
    s
}

/// A Unity (built-in pipeline) surface shader: the coefficient textures and
/// the time as material properties, [`hlsl`]'s evaluation, and the
/// StandardSpecular lighting model fed with Diffuse (albedo), Specular,
/// 1 - Roughness (smoothness) and the tangent-space Normal, those the
/// material has.
pub fn shaderlab(material: &Material) -> String {
    let mut props = String::from("        _MaterialTime (\"Time t\", Range(0, 1)) = 0\n");
    props +=
        &per_texture(material, |_, id, name, k| format!("        {id}_{k} (\"{name}-{k}.exr (linear, no sRGB)\", 2D) = \"black\" {{}}\n"));
    let has = |name: &str| material.param(name).map(|r| r.len());
    let decode =
        |v: &str| if material.encoding == Encoding::Srgb { format!("GammaToLinearSpace(saturate({v}))") } else { format!("saturate({v})") };
    let mut surf = String::from("            Material m = EvaluateMaterial(IN.uv_diffuse_0, _MaterialTime);\n");
    surf += &match has("diffuse") {
        Some(3) => format!("            o.Albedo = {};\n", decode("m.diffuse")),
        Some(1) => format!("            o.Albedo = {};\n", decode("m.diffuse.xxx")),
        _ => "            o.Albedo = 0.5;\n".into(),
    };
    surf += &match has("specular") {
        Some(3) => format!("            o.Specular = {};\n", decode("m.specular")),
        Some(1) => format!("            o.Specular = {};\n", decode("m.specular.xxx")),
        // As the previews: an albedo-only capture's colour already holds its sheen.
        _ => "            o.Specular = 0.0;\n".into(),
    };
    surf += match has("roughness") {
        Some(1) => "            o.Smoothness = 1.0 - saturate(m.roughness);\n",
        _ => "            o.Smoothness = 0.5;\n",
    };
    if has("normal") == Some(3) {
        surf += "            o.Normal = normalize(m.normal * 2.0 - 1.0);\n";
    }
    let uv_name = material.params.first().map_or("diffuse".to_string(), |p| ident(&p.name));
    let surf = surf.replace("IN.uv_diffuse_0", &format!("IN.uv_{uv_name}_0"));
    format!(
        "// patina: spatio-temporal material for Unity's built-in pipeline (surface shader).\n\
         // Import every {{Name}}-{{i}}.exr with sRGB (Color Texture) off, and animate _MaterialTime in [0, 1].\n\
         Shader \"Patina/SpatioTemporal\" {{\n    Properties {{\n{props}    }}\n    SubShader {{\n        Tags {{ \"RenderType\" = \"Opaque\" }}\n        CGPROGRAM\n        #pragma surface surf StandardSpecular fullforwardshadows\n        #pragma target 4.0\n{}\n        float _MaterialTime;\n        struct Input {{ float2 uv_{uv_name}_0; }};\n\n        void surf(Input IN, inout SurfaceOutputStandardSpecular o) {{\n{surf}        }}\n        ENDCG\n    }}\n    FallBack \"Diffuse\"\n}}\n",
        hlsl(material)
    )
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
        let h = hlsl(&m);
        assert_eq!(h.matches("Texture2D ").count(), 12);
        let unity = shaderlab(&m);
        assert!(unity.contains(&h), "the Unity shader embeds the HLSL evaluation");
        assert!(unity.contains("o.Smoothness = 1.0 - saturate(m.roughness);"));
    }

    fn full_material() -> Material {
        let params = vec![
            Param { name: "Diffuse".into(), channels: 3 },
            Param { name: "Specular".into(), channels: 3 },
            Param { name: "Roughness".into(), channels: 1 },
            Param { name: "Normal".into(), channels: 3 },
            Param { name: "Height".into(), channels: 1 },
        ];
        Material::new(3, params, crate::Image::new(2, 2, 11 * 4)).unwrap()
    }

    /// The WGSL parses and validates with naga (wgpu's compiler).
    #[test]
    fn wgsl_compiles() {
        for m in [full_material(), Material::new(2, drying_wood_params(), crate::Image::new(2, 2, 21)).unwrap()] {
            let src = wgsl(&m);
            let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{}\n{src}", e.emit_to_string(&src)));
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{e:?}\n{src}"));
        }
    }

    /// Compile `src` with glslang (`glslangValidator`, from the
    /// glslang-tools package, which CI installs) with `args`; `false`
    /// (saying so) when the tool is missing.
    fn glslang(args: &[&str], src: &str, file_name: &str) -> bool {
        let tool = "glslangValidator";
        if std::process::Command::new(tool).arg("--version").output().is_err() {
            eprintln!("SKIPPED: {tool} not found (apt-get install glslang-tools)");
            return false;
        }
        let dir = std::env::temp_dir().join(format!("patina-shader-{}-{file_name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join(file_name);
        std::fs::write(&file, src).unwrap();
        let out = std::process::Command::new(tool).args(args).arg("-o").arg(dir.join("out.spv")).arg(&file).output().unwrap();
        std::fs::remove_dir_all(&dir).ok();
        assert!(out.status.success(), "{}\n{}\n{src}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        true
    }

    /// The GLSL, with a fragment main that uses the material, compiles
    /// with glslang for OpenGL (naga's GLSL front end has no combined
    /// samplers, which OpenGL needs).
    #[test]
    fn glsl_compiles() {
        let src = glsl(&full_material())
            + "\nlayout(location = 0) in vec2 v_uv;\nlayout(location = 0) out vec4 colour;\nvoid main() {\n    Material m = evaluateMaterial(v_uv, 0.5);\n    colour = vec4(m.diffuse * m.roughness + m.normal * m.height + m.specular, 1.0);\n}\n";
        glslang(&["-G"], &src, "material.frag");
    }

    /// The HLSL, with a pixel shader that uses the material, compiles with
    /// glslang's HLSL front end.
    #[test]
    fn hlsl_compiles() {
        let src = hlsl(&full_material())
            + "\nfloat4 main(float2 uv : TEXCOORD0) : SV_Target {\n    Material m = EvaluateMaterial(uv, 0.5);\n    return float4(m.diffuse * m.roughness + m.normal * m.height + m.specular, 1.0);\n}\n";
        glslang(&["-D", "-V", "-S", "frag", "-e", "main"], &src, "material.hlsl");
    }
}

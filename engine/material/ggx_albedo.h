#pragma once
// The directional albedo of the GGX specular lobe with Schlick's Fresnel, for the energy-
// conserving base layer of glTF's metallic-roughness material (Kulla & Conty 2017, "Revisiting
// Physically Based Shading at Imageworks"). Schlick's F is linear in f0 and f90, so the albedo
// is E(μ, α) = f0·a(μ, α) + f90·b(μ, α): two tables serve every f0, index and specular factor.
// They are integrated when the engine is built, with a fixed stratified quadrature
// (ggx_albedo_tables.h), so a process reads them from its first pixel at no cost.
namespace tessera {

struct GgxAlbedo {
    float a = 0.f, b = 0.f;  // the albedo is f0·a + f90·b
    float operator()(float f0, float f90) const { return f0 * a + f90 * b; }
};

// Directional albedo seen from cos θo = mu, bilinear in (mu, √α).
GgxAlbedo ggx_albedo(float mu, float alpha);
// Its cosine-weighted average over the hemisphere, 2∫E(μ)μ dμ.
GgxAlbedo ggx_albedo_average(float alpha);

}  // namespace tessera

// Particle generation: each body is filled with a regular lattice of particles_per_cell points per
// cell (n per axis at the cell-relative positions (k + 1/2) / n), keeping the points inside it.
// Jittered seeding moves each point to a random place in its lattice cell, (k + 1/2 + u) / n
// with u in [-1/2, 1/2) per axis, repeatable for the scene's seed.
#pragma once

#include <array>

#include "sim/core/particles.h"
#include "sim/scene/scene.h"

namespace snowsim {

// True when point p (scene coordinates, 3 entries; z ignored for 2D shapes) lies in the body.
bool bodyContains(const Body& body, const Vec3& p, int shape_dimension);

// Distance between neighbouring particles of a body's lattice.
double particleSpacing(const Scene& scene, const Body& body);

// The offset u of lattice point k along an axis, in [-1/2, 1/2): a hash of the seed, the body's
// index, k and the axis, so a body's particles do not depend on the order they are made in.
double latticeJitter(int seed, int body, const std::array<int, 3>& k, int axis);

// Throws a FieldError naming the body's size field (scale, size or radius) when a body (not a
// points body) is narrower along an axis than its particle spacing: it would hold no particles,
// or a single layer; most likely a mesh in millimetres read as metres. Of the scene as it runs
// (after --scale and --quality), before anything is written.
void refuseBodiesNarrowerThanTheirParticles(const Scene& scene);

// Fills every body of the scene. A 2D-authored scene run in 3D extrudes each body through the
// slab's whole depth. Throws InputError when a body holds no particle once filled.
template <int D>
Particles<D> sampleBodies(const Scene& scene);

// The particles sampleBodies makes, counted without keeping them (a Poisson-disk body's by its
// lattice, within a few percent): what a run's memory and cost are estimated from.
long countBodyParticles(const Scene& scene);

}  // namespace snowsim

// Particles as one flat array per attribute (structure of arrays). A solver may store them in any
// order (MPM keeps them sorted by grid block); `id` is each particle's index at creation, the order
// snapshots and files use.
#pragma once

#include <vector>

#include "sim/core/math.h"

namespace snowsim {

// T: the scalar of the solver's state (MPM may keep it in single precision); what solvers hand
// out is in double.
template <int D, class T = Real>
struct Particles {
  using Scalar = T;
  std::vector<Vec<D, T>> x;  // position, m
  std::vector<Vec<D, T>> v;  // velocity, m/s
  std::vector<T> mass;       // kg
  std::vector<T> volume;     // initial volume V_p^0, m^D (set on the first step): rho_p^0 = m / V
  std::vector<int> body;     // index of the body the particle was generated in
  std::vector<int> id;       // index at creation: stable however the solver reorders them

  int size() const { return static_cast<int>(x.size()); }

  // f(array) for every per-particle array: what a reordering must permute. A container that adds
  // arrays extends this; tests check that it names every member.
  template <class F>
  void forEachArray(F&& f) {
    f(x), f(v), f(mass), f(volume), f(body), f(id);
  }

  // The positions in creation order, whatever order the particles are stored in.
  std::vector<Vec<D, T>> positionsById() const {
    std::vector<Vec<D, T>> by_id(x.size());
    for (int i = 0; i < size(); ++i) by_id[id[i]] = x[i];
    return by_id;
  }
  void add(const Vec<D, T>& position, const Vec<D, T>& velocity, T m, int body_index) {
    x.push_back(position);
    v.push_back(velocity);
    mass.push_back(m);
    volume.push_back(0);
    body.push_back(body_index);
    id.push_back(size() - 1);
  }
};

// The common attributes of `from` in the scalar of `to` (a float converts to double exactly).
template <int D, class From, class To>
void convertParticles(const Particles<D, From>& from, Particles<D, To>& to) {
  const auto castEach = [](const auto& vectors, auto& into) {
    into.resize(vectors.size());
    for (size_t i = 0; i < vectors.size(); ++i) into[i] = vectors[i].template cast<To>();
  };
  castEach(from.x, to.x);
  castEach(from.v, to.v);
  to.mass.assign(from.mass.begin(), from.mass.end());
  to.volume.assign(from.volume.begin(), from.volume.end());
  to.body = from.body;
  to.id = from.id;
}

}  // namespace snowsim

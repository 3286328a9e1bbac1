#pragma once
/// \file FrictionLaw.hpp
/// The friction law of a contact coupling (docs/theory.md#friction): none (frictionless), Tresca
/// with a given slip bound (a traction, Pa) or Coulomb with a friction coefficient. ContactModel
/// keeps one per coupling; solveFriction (Friction.hpp) solves a model with friction.

namespace obs {

struct FrictionLaw {
  enum class Type { None, Tresca, Coulomb };
  Type type = Type::None;
  double value = 0;  ///< Tresca: the slip bound; Coulomb: the coefficient mu (>= 0; 0: frictionless)
};

}  // namespace obs

#pragma once
/// \file Mutator.hpp
/// A deterministic mutation engine for the parser fuzz driver (fuzz_parsers.cpp).
///
/// Input number i of a run with seed s is a pure function of (s, i, corpus): a SplitMix64 stream
/// seeded from both picks a corpus file and applies 1-6 mutations to it. So any input can be
/// regenerated from its number alone (a crashed worker process is replaced and the crashing input
/// rebuilt by the parent), and a failure is reproduced by `fuzz_parsers --replay`.
///
/// Mutations: generic byte-level ones (bit flips, byte overwrites with interesting bytes,
/// insertion and deletion of short runs, duplication of a range, truncation, splices between two
/// corpus files, a chunk repeated up to a few thousand times), numeric ones (a number in the text
/// replaced by an edge value: nan, inf, 1e308, 4.9e-324, -0, 2^31, 2^63, 1e400, ...), and
/// dialect-aware ones: for TOML, values replaced by other types, lines deleted, duplicated and
/// swapped, known section headers and keys inserted, deeply nested arrays; for expressions,
/// identifiers replaced by other functions and variables, operators inserted, calls wrapped and
/// nested; for Gmsh files, lines deleted, duplicated and swapped, counts and tags replaced by edge
/// integers, section names exchanged.
#include <cstdint>
#include <string>
#include <vector>

namespace obs::fuzz {

enum class Dialect { Toml, Expression, Gmsh };

/// SplitMix64 (Steele, Lea, Flood 2014): a small, fast generator with a 64-bit state.
class Rng {
public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  /// Uniform in [0, n) (n > 0; the modulo bias is irrelevant here).
  std::size_t below(std::size_t n) { return static_cast<std::size_t>(next() % n); }
  bool chance(int percent) { return below(100) < static_cast<std::size_t>(percent); }

private:
  std::uint64_t state_;
};

class Mutator {
public:
  /// `corpus` must not be empty; inputs are capped at `maxSize` bytes.
  Mutator(std::vector<std::string> corpus, Dialect dialect, std::size_t maxSize = 1 << 18);

  /// Input number `index` of the run with seed `seed`.
  std::string input(std::uint64_t seed, std::uint64_t index) const;

  const std::vector<std::string>& corpus() const { return corpus_; }

private:
  void mutate(std::string& s, Rng& rng) const;
  void mutateBytes(std::string& s, Rng& rng) const;
  void mutateNumber(std::string& s, Rng& rng) const;
  void mutateToml(std::string& s, Rng& rng) const;
  void mutateExpression(std::string& s, Rng& rng) const;
  void mutateGmsh(std::string& s, Rng& rng) const;

  std::vector<std::string> corpus_;
  Dialect dialect_;
  std::size_t maxSize_;
};

}  // namespace obs::fuzz

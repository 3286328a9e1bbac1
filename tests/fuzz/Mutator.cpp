/// \file Mutator.cpp
/// The mutations of Mutator.hpp. Each one takes the text and the random stream and edits the text
/// in place; positions are always drawn inside the current text, so every mutation is defined for
/// every input, including the empty one.
#include "Mutator.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <string_view>
#include <utility>

namespace obs::fuzz {

namespace {

constexpr std::array<std::string_view, 34> kEdgeNumbers{
    "nan",   "-nan",  "inf",      "-inf",     "+inf",   "1e308",   "-1e308",
    "1e-308", "4.9e-324", "1.7976931348623157e308", "1e400", "-1e400", "0",
    "-0",    "0.0",   "-1",       "1",        "2",      "1e-12",   "1e12",
    "999",   "1000",  "1001",     "100000",   "2147483647", "2147483648", "-2147483649",
    "4294967296", "9223372036854775807", "9223372036854775808", "-9223372036854775809",
    "0.4999999999", "0.5", "1e+5"};

constexpr std::array<char, 16> kInterestingBytes{'\0', '\n', '\r', '\t', ' ',  '"',  '\'', '[',
                                                 ']',  '{',  '}',  '=',  '#',  '\\', '\x7f', '\xff'};

std::string_view pick(Rng& rng, const auto& list) { return list[rng.below(list.size())]; }

std::vector<std::string> splitLines(const std::string& s) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t end = s.find('\n', start);
    if (end == std::string::npos) {
      lines.push_back(s.substr(start));
      break;
    }
    lines.push_back(s.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

std::string joinLines(const std::vector<std::string>& lines) {
  std::string s;
  for (std::size_t i = 0; i < lines.size(); ++i) s += (i ? "\n" : "") + lines[i];
  return s;
}

bool isNumberChar(char c) {
  return std::isdigit(static_cast<unsigned char>(c)) || c == '.' || c == 'e' || c == 'E' ||
         c == '+' || c == '-';
}

/// Ranges [begin, end) of the numbers (digit runs with sign, point and exponent) in s.
std::vector<std::pair<std::size_t, std::size_t>> numberRanges(const std::string& s) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t i = 0; i < s.size();) {
    if (!std::isdigit(static_cast<unsigned char>(s[i]))) {
      ++i;
      continue;
    }
    std::size_t b = i, e = i;
    while (b > 0 && (s[b - 1] == '-' || s[b - 1] == '.')) --b;
    while (e < s.size() && isNumberChar(s[e])) ++e;
    out.emplace_back(b, e);
    i = e;
  }
  return out;
}

/// Ranges of identifiers (letters, digits, '_', starting with a letter).
std::vector<std::pair<std::size_t, std::size_t>> identifierRanges(const std::string& s) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t i = 0; i < s.size();) {
    if (!std::isalpha(static_cast<unsigned char>(s[i]))) {
      ++i;
      continue;
    }
    std::size_t e = i;
    while (e < s.size() && (std::isalnum(static_cast<unsigned char>(s[e])) || s[e] == '_')) ++e;
    out.emplace_back(i, e);
    i = e;
  }
  return out;
}

std::string repeated(std::string_view unit, std::size_t n) {
  std::string out;
  out.reserve(unit.size() * n);
  for (std::size_t i = 0; i < n; ++i) out += unit;
  return out;
}

}  // namespace

std::uint64_t Rng::next() {
  std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

Mutator::Mutator(std::vector<std::string> corpus, Dialect dialect, std::size_t maxSize)
    : corpus_(std::move(corpus)), dialect_(dialect), maxSize_(maxSize) {}

std::string Mutator::input(std::uint64_t seed, std::uint64_t index) const {
  Rng rng(seed * 0x2545f4914f6cdd1dULL ^ (index + 1) * 0x9e3779b97f4a7c15ULL);
  rng.next();
  std::string s = corpus_[rng.below(corpus_.size())];
  const std::size_t rounds = 1 + rng.below(rng.chance(20) ? 12 : 4);
  for (std::size_t r = 0; r < rounds; ++r) {
    mutate(s, rng);
    if (s.size() > maxSize_) s.resize(maxSize_);
  }
  return s;
}

void Mutator::mutate(std::string& s, Rng& rng) const {
  const std::size_t kind = rng.below(10);
  if (kind < 3) return mutateBytes(s, rng);
  if (kind < 5) return mutateNumber(s, rng);
  switch (dialect_) {
    case Dialect::Toml:
      return mutateToml(s, rng);
    case Dialect::Expression:
      return mutateExpression(s, rng);
    case Dialect::Gmsh:
      return mutateGmsh(s, rng);
  }
}

void Mutator::mutateBytes(std::string& s, Rng& rng) const {
  const std::size_t pos = rng.below(s.size() + 1);
  switch (rng.below(9)) {
    case 0:  // flip a bit
      if (!s.empty()) s[rng.below(s.size())] ^= static_cast<char>(1u << rng.below(8));
      break;
    case 1:  // overwrite a byte with an interesting one
      if (!s.empty()) s[rng.below(s.size())] = kInterestingBytes[rng.below(kInterestingBytes.size())];
      break;
    case 2: {  // insert random bytes
      const std::size_t n = 1 + rng.below(8);
      std::string bytes;
      for (std::size_t i = 0; i < n; ++i) bytes += static_cast<char>(rng.below(256));
      s.insert(pos, bytes);
      break;
    }
    case 3:  // insert interesting bytes
      s.insert(pos, 1 + rng.below(4), kInterestingBytes[rng.below(kInterestingBytes.size())]);
      break;
    case 4:  // delete a run
      if (pos < s.size()) s.erase(pos, 1 + rng.below(std::min<std::size_t>(32, s.size() - pos)));
      break;
    case 5: {  // duplicate a range
      if (s.empty()) break;
      const std::size_t from = rng.below(s.size());
      const std::size_t len = 1 + rng.below(std::min<std::size_t>(64, s.size() - from));
      s.insert(pos, s.substr(from, len));
      break;
    }
    case 6:  // truncate
      s.resize(pos);
      break;
    case 7: {  // splice: a chunk of another corpus file replaces the tail or is inserted
      const std::string& other = corpus_[rng.below(corpus_.size())];
      const std::size_t from = rng.below(other.size() + 1);
      const std::size_t len = rng.below(other.size() - from + 1);
      if (rng.chance(50))
        s = s.substr(0, pos) + other.substr(from);
      else
        s.insert(pos, other.substr(from, len));
      break;
    }
    case 8: {  // a short chunk repeated many times (nesting, long lines, size)
      if (s.empty()) break;
      const std::size_t from = rng.below(s.size());
      const std::size_t len = 1 + rng.below(std::min<std::size_t>(8, s.size() - from));
      const std::size_t times = 2 + rng.below(rng.chance(30) ? 20000 : 200);
      s.insert(pos, repeated(s.substr(from, len), times));
      break;
    }
  }
}

void Mutator::mutateNumber(std::string& s, Rng& rng) const {
  const auto ranges = numberRanges(s);
  if (ranges.empty()) {
    s.insert(rng.below(s.size() + 1), pick(rng, kEdgeNumbers));
    return;
  }
  const auto [b, e] = ranges[rng.below(ranges.size())];
  std::string replacement(pick(rng, kEdgeNumbers));
  if (rng.chance(15)) {  // a small perturbation of the number instead
    replacement = s.substr(b, e - b);
    if (!replacement.empty()) replacement[rng.below(replacement.size())] = "0123456789-.e+"[rng.below(14)];
  }
  s.replace(b, e - b, replacement);
}

void Mutator::mutateToml(std::string& s, Rng& rng) const {
  static constexpr std::array<std::string_view, 16> kValues{
      "\"\"", "\"x\"", "[]", "[[]]", "{}", "{ a = 1 }", "true", "false", "1979-05-27T07:32:00Z",
      "[1, \"a\"]", "[1, 2, 3, 4]", "\"sin(x\"", "'''\nmulti\n'''", "0x10", "1_000", "\"nan*x\""};
  static constexpr std::array<std::string_view, 14> kSections{
      "[mesh]",    "[material]", "[[dirichlet]]", "[[neumann]]",  "[body_force]", "[contact]",
      "[solver]",  "[output]",   "[adaptivity]",  "[dynamics]",   "[mesh.x]",     "[[mesh]]",
      "[unknown]", "[contact.obstacle]"};
  static constexpr std::array<std::string_view, 40> kKeys{
      "generator", "type",      "cells",     "lower",        "upper",         "file",
      "refine",    "E",         "nu",        "density",      "boundary",      "value",
      "components", "traction", "pressure",  "obstacle",     "gap",           "normal",
      "direction", "centre",    "radius",    "tolerance",    "max_iterations", "pre_smoothing",
      "post_smoothing", "directory", "vtk",  "csv",          "plots",         "estimator",
      "marking",   "theta",     "steps",     "scheme",       "tau",           "initial_velocity",
      "width",     "arc_radius", "height",   "reference"};
  auto lines = splitLines(s);
  const std::size_t at = rng.below(lines.size());
  switch (rng.below(9)) {
    case 0: {  // replace a value by another type
      const std::size_t eq = lines[at].find('=');
      if (eq != std::string::npos) lines[at] = lines[at].substr(0, eq + 1) + " " + std::string(pick(rng, kValues));
      break;
    }
    case 1:
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(at));
      break;
    case 2:
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at), lines[rng.below(lines.size())]);
      break;
    case 3:
      std::swap(lines[at], lines[rng.below(lines.size())]);
      break;
    case 4:
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at), std::string(pick(rng, kSections)));
      break;
    case 5: {  // a known key with a value taken from another line or the value list
      const auto& donor = lines[rng.below(lines.size())];
      const std::size_t eq = donor.find('=');
      const std::string value = eq != std::string::npos && rng.chance(60)
                                    ? donor.substr(eq + 1)
                                    : " " + std::string(pick(rng, kValues));
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at),
                   std::string(pick(rng, kKeys)) + " =" + value);
      break;
    }
    case 6: {  // rename a key
      const std::size_t eq = lines[at].find('=');
      if (eq != std::string::npos) lines[at] = std::string(pick(rng, kKeys)) + " " + lines[at].substr(eq);
      break;
    }
    case 7: {  // deeply nested arrays or inline tables
      const std::size_t depth = 1 + rng.below(rng.chance(30) ? 50000 : 100);
      const bool table = rng.chance(30);
      const std::string open = table ? "{a=" : "[", close = table ? "}" : "]";
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at),
                   "nested = " + repeated(open, depth) + "1" + repeated(close, depth));
      break;
    }
    case 8: {  // a long string or key
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at),
                   "k" + repeated("x", rng.below(5000)) + " = \"" + repeated("y", rng.below(5000)) + "\"");
      break;
    }
  }
  s = joinLines(lines);
}

void Mutator::mutateExpression(std::string& s, Rng& rng) const {
  static constexpr std::array<std::string_view, 28> kNames{
      "sin", "cos", "tan",  "asin",  "acos", "atan", "sinh", "cosh", "tanh", "exp",
      "log", "sqrt", "abs", "floor", "ceil", "min",  "max",  "pow",  "atan2", "x",
      "y",   "z",   "t",    "pi",    "e",    "sinn", "_",    "xx"};
  static constexpr std::array<std::string_view, 12> kOperators{
      "+", "-", "*", "/", "^", ",", "(", ")", "()", "--", "**", "e"};
  const std::size_t pos = rng.below(s.size() + 1);
  switch (rng.below(6)) {
    case 0: {  // replace an identifier
      const auto ids = identifierRanges(s);
      if (ids.empty()) break;
      const auto [b, e] = ids[rng.below(ids.size())];
      s.replace(b, e - b, pick(rng, kNames));
      break;
    }
    case 1:
      s.insert(pos, pick(rng, kOperators));
      break;
    case 2:  // wrap in a call
      s = std::string(pick(rng, kNames)) + "(" + s + (rng.chance(30) ? ", y)" : ")");
      break;
    case 3: {  // nesting: parentheses, unary minus, powers
      const std::size_t n = 1 + rng.below(rng.chance(30) ? 5000 : 300);
      const std::string_view unit = std::array<std::string_view, 4>{"(", "-", "2^", "sin("}[rng.below(4)];
      std::string close;
      if (unit == "(" || unit == "sin(") close = repeated(")", n);
      s = repeated(unit, n) + s + close;
      break;
    }
    case 4: {  // long chains a + a + ...
      const std::size_t n = 1 + rng.below(rng.chance(5) ? 200000 : rng.chance(30) ? 20000 : 200);
      const std::string_view op = pick(rng, kOperators);
      s = s + repeated(std::string(op) + "x", n);
      break;
    }
    case 5:  // splice with another corpus expression through an operator
      s += std::string(pick(rng, kOperators)) + corpus_[rng.below(corpus_.size())];
      break;
  }
}

void Mutator::mutateGmsh(std::string& s, Rng& rng) const {
  static constexpr std::array<std::string_view, 14> kHeaders{
      "$MeshFormat", "$EndMeshFormat", "$Nodes",    "$EndNodes",         "$Elements",
      "$EndElements", "$Entities",     "$EndEntities", "$PhysicalNames", "$EndPhysicalNames",
      "$Comments",   "$PartitionedEntities", "$NodeData", "$End"};
  static constexpr std::array<std::string_view, 14> kIntegers{
      "0", "-1", "1", "2", "3", "4", "7", "8", "15", "99", "2147483647", "2147483648",
      "9223372036854775807", "1000000000000"};
  auto lines = splitLines(s);
  const std::size_t at = rng.below(lines.size());
  switch (rng.below(7)) {
    case 0:
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(at));
      break;
    case 1:
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at), lines[rng.below(lines.size())]);
      break;
    case 2:
      std::swap(lines[at], lines[rng.below(lines.size())]);
      break;
    case 3: {  // replace one integer token of a line (counts, tags, types, dimensions)
      auto ranges = numberRanges(lines[at]);
      if (ranges.empty()) break;
      const auto [b, e] = ranges[rng.below(ranges.size())];
      lines[at].replace(b, e - b, pick(rng, kIntegers));
      break;
    }
    case 4:
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at), std::string(pick(rng, kHeaders)));
      break;
    case 5:  // truncate at a line
      lines.resize(at + 1);
      break;
    case 6: {  // drop or add a token
      auto& line = lines[at];
      const std::size_t space = line.rfind(' ');
      if (rng.chance(50) && space != std::string::npos)
        line.resize(space);
      else
        line += " " + std::string(pick(rng, kIntegers));
      break;
    }
  }
  s = joinLines(lines);
}

}  // namespace obs::fuzz

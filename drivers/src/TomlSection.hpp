#pragma once
/// \file TomlSection.hpp
/// Checked access to one table of a scene file (internal to the scene parser): every accessor
/// checks presence and type and reports problems as one-line obs::Errors naming the file, line,
/// section and key, e.g. "scene.toml:7: [material] E must be a number, got a string".
#include <toml.hpp>

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "obs/drivers/Expression.hpp"
#include "obs/drivers/Scene.hpp"

namespace obs::drivers {

/// File name given to the TOML values of --set overrides; messages about such a value say
/// "<scene> (from --set): " instead of "<scene>:<line>: " (TomlSection.cpp).
inline constexpr const char* kOverrideSource = "(from --set)";

/// "file:line: " for a TOML value (file name as passed to the TOML parser).
std::string whereOf(const std::string& fileName, const toml::value& v);
/// The literal text of a value as written in the file (falls back to its TOML serialisation).
std::string literalOf(const toml::value& v);
/// "a string", "an integer", ... for messages.
std::string typeNameOf(const toml::value& v);

/// Deepest nesting of arrays and inline tables a scene may use (scenes need 2).
inline constexpr int kMaxTomlNesting = 32;

/// Throws obs::Error "<fileName>:<line>: TOML arrays and inline tables nested deeper than
/// kMaxTomlNesting levels" if `text` nests '[' / '{' (outside strings and comments) that deeply,
/// or "... TOML key with more than kMaxTomlNesting dotted parts" for a key or table header like
/// [a.b.c...]. Called before toml::parse, whose recursive descent would otherwise overflow the
/// stack (depth ~10^4) or take minutes (inline tables, dotted keys) on such input.
void checkTomlNesting(std::string_view text, const std::string& fileName);

class TomlSection;
/// The entries of a TOML array as finite numbers (integers converted); any other entry is an error
/// of section s naming "label[i]". The caller checks that v is an array of the right length.
std::vector<double> finiteNumberEntries(const TomlSection& s, const toml::value& v, const std::string& label);

/// Names, file names and keywords (string values) are one line of text: a line break or another
/// control character in the string `v` is an error of section s naming `label` (such text would
/// also break the one-line messages that quote it). string() and boundary() check this.
void checkOneLine(const TomlSection& s, const toml::value& v, const std::string& label);

class TomlSection {
public:
  /// `title` is how the section is written in messages, "[material]" or "[[dirichlet]]".
  /// Throws if the table holds keys not in `allowed`.
  TomlSection(std::string fileName, std::string title, const toml::value& table,
              const std::vector<std::string>& allowed);

  bool has(const std::string& key) const;
  int line() const;                                     ///< line of the section header (0: unknown)
  int line(const std::string& key) const;               ///< line of a key's value (0 if absent)
  const toml::value& at(const std::string& key) const;  ///< throws "... is missing" if absent

  double number(const std::string& key) const;  ///< integer or float, finite
  long long integer(const std::string& key) const;
  std::string string(const std::string& key) const;
  bool boolean(const std::string& key) const;
  /// A number or an expression string.
  Expression expression(const std::string& key) const;
  /// An array of numbers or expression strings.
  VectorValue vector(const std::string& key) const;
  /// A boundary name (string) or id (non-negative integer).
  BoundaryRef boundary(const std::string& key) const;

  /// An element of an array or the value itself, turned into an expression; `label` names it.
  Expression expressionOf(const toml::value& v, const std::string& label) const;

  /// Throws "<file>:<line of key>: <title> <key> <message>".
  [[noreturn]] void fail(const std::string& key, const std::string& message) const;
  /// Throws "<file>:<line of v>: <title> <label> <message>".
  [[noreturn]] void failAt(const toml::value& v, const std::string& label,
                           const std::string& message) const;

  const std::string& title() const { return title_; }
  const std::string& fileName() const { return fileName_; }

private:
  std::string fileName_;
  std::string title_;
  const toml::value& table_;
};

}  // namespace obs::drivers

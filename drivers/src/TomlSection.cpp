#include "TomlSection.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "obs/mesh/Error.hpp"

namespace obs::drivers {

namespace {

int lineOf(const toml::value& v) {
  const toml::source_location loc = v.location();
  if (loc.file_name() == "unknown file" || loc.file_name() == kOverrideSource) return 0;
  return static_cast<int>(loc.line());
}

std::string prefix(const std::string& fileName, int line) {
  return line > 0 ? fileName + ":" + std::to_string(line) + ": " : fileName + ": ";
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

}  // namespace

std::string whereOf(const std::string& fileName, const toml::value& v) {
  if (v.location().file_name() == kOverrideSource) return fileName + " " + kOverrideSource + ": ";
  return prefix(fileName, lineOf(v));
}

void checkTomlNesting(std::string_view text, const std::string& fileName) {
  int depth = 0, line = 1, dots = 0;
  bool key = true;  // in the key or table header at the start of a line (before '=')
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      dots = 0;
      key = depth == 0;
    } else if (c == '=') {
      key = false;
    } else if (c == '.' && key) {  // a.b.c = 1 and [a.b.c] nest tables as deeply as arrays do
      if (++dots >= kMaxTomlNesting)
        throw Error(fileName + ":" + std::to_string(line) + ": TOML key with more than " +
                    std::to_string(kMaxTomlNesting) + " dotted parts");
    } else if (c == '#') {  // comment to the end of the line
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
    } else if (c == '"' || c == '\'') {  // basic or literal string, one-line or multi-line
      const bool multi = text.substr(i, 3) == std::string(3, c);
      const std::string close = multi ? std::string(3, c) : std::string(1, c);
      std::size_t j = i + close.size();
      while (j < text.size() && text.substr(j, close.size()) != close) {
        if (c == '"' && text[j] == '\\') ++j;  // escaped character
        if (j < text.size() && text[j] == '\n') {
          ++line;
          if (!multi) break;  // unterminated: toml::parse reports it
        }
        ++j;
      }
      i = std::min(j + close.size(), text.size()) - 1;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxTomlNesting)
        throw Error(fileName + ":" + std::to_string(line) +
                    ": TOML arrays and inline tables nested deeper than " +
                    std::to_string(kMaxTomlNesting) + " levels");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

std::string literalOf(const toml::value& v) {
  const toml::source_location loc = v.location();
  const std::string& line = loc.line_str();
  const std::size_t begin = loc.column() - 1, size = loc.region();
  if (loc.file_name() != "unknown file" && begin + size <= line.size() && size > 0)
    return line.substr(begin, size);
  std::ostringstream os;
  os << v;
  std::string s = os.str();
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  // messages are one line: a multi-line string or table shows its line breaks as '?'
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  constexpr std::size_t kMaxLength = 200;
  if (s.size() > kMaxLength) s = s.substr(0, kMaxLength) + "...";
  return s;
}

std::string typeNameOf(const toml::value& v) {
  switch (v.type()) {
    case toml::value_t::boolean:
      return "a boolean";
    case toml::value_t::integer:
      return "an integer";
    case toml::value_t::floating:
      return "a float";
    case toml::value_t::string:
      return "a string";
    case toml::value_t::array:
      return "an array";
    case toml::value_t::table:
      return "a table";
    case toml::value_t::empty:
      return "nothing";
    default:
      return "a date/time";
  }
}

TomlSection::TomlSection(std::string fileName, std::string title, const toml::value& table,
                         const std::vector<std::string>& allowed)
    : fileName_(std::move(fileName)), title_(std::move(title)), table_(table) {
  if (!table_.is_table())
    throw Error(whereOf(fileName_, table_) + title_ + " must be a table, got " +
                typeNameOf(table_));
  // Report the first unknown key in file order (the table itself is unordered).
  const toml::value* first = nullptr;
  std::string firstKey;
  for (const auto& [key, value] : table_.as_table()) {
    const bool known =
        std::any_of(allowed.begin(), allowed.end(), [&](const std::string& a) { return key == a; });
    if (!known && (!first || lineOf(value) < lineOf(*first))) {
      first = &value;
      firstKey = key;
    }
  }
  if (first)
    throw Error(whereOf(fileName_, *first) + title_ + " unknown key '" + firstKey +
                "' (allowed keys: " + joined(allowed) + ")");
}

bool TomlSection::has(const std::string& key) const { return table_.as_table().count(key) > 0; }

int TomlSection::line() const { return lineOf(table_); }

int TomlSection::line(const std::string& key) const {
  return has(key) ? lineOf(table_.as_table().at(key)) : 0;
}

const toml::value& TomlSection::at(const std::string& key) const {
  const auto& t = table_.as_table();
  const auto it = t.find(key);
  if (it == t.end()) throw Error(whereOf(fileName_, table_) + title_ + " " + key + " is missing");
  return it->second;
}

void TomlSection::fail(const std::string& key, const std::string& message) const {
  throw Error((has(key) ? whereOf(fileName_, table_.as_table().at(key)) : prefix(fileName_, line())) +
              title_ + " " + key + " " + message);
}

void TomlSection::failAt(const toml::value& v, const std::string& label,
                         const std::string& message) const {
  throw Error(whereOf(fileName_, v) + title_ + " " + label + " " + message);
}

double TomlSection::number(const std::string& key) const {
  const toml::value& v = at(key);
  double x = 0;
  if (v.is_integer())
    x = static_cast<double>(v.as_integer());
  else if (v.is_floating())
    x = v.as_floating();
  else
    fail(key, "must be a number, got " + typeNameOf(v));
  if (!std::isfinite(x)) fail(key, "= " + literalOf(v) + " must be finite");
  return x;
}

long long TomlSection::integer(const std::string& key) const {
  const toml::value& v = at(key);
  if (!v.is_integer()) fail(key, "must be an integer, got " + typeNameOf(v));
  return v.as_integer();
}

void checkOneLine(const TomlSection& s, const toml::value& v, const std::string& label) {
  for (const char c : v.as_string().str)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      s.failAt(v, label, "must be one line of text without control characters (line breaks, tabs)");
}

std::string TomlSection::string(const std::string& key) const {
  const toml::value& v = at(key);
  if (!v.is_string()) fail(key, "must be a string, got " + typeNameOf(v));
  checkOneLine(*this, v, key);
  return v.as_string().str;
}

bool TomlSection::boolean(const std::string& key) const {
  const toml::value& v = at(key);
  if (!v.is_boolean()) fail(key, "must be true or false, got " + typeNameOf(v));
  return v.as_boolean();
}

Expression TomlSection::expressionOf(const toml::value& v, const std::string& label) const {
  if (v.is_integer()) return Expression(static_cast<double>(v.as_integer()));
  if (v.is_floating()) {
    if (!std::isfinite(v.as_floating())) failAt(v, label, "= " + literalOf(v) + " must be finite");
    return Expression(v.as_floating());
  }
  if (v.is_string()) {
    try {
      return Expression::parse(v.as_string().str);
    } catch (const ExpressionError& e) {
      failAt(
          v, label,
          "= \"" + e.excerpt() + "\": " + e.reason() + " at position " + std::to_string(e.position()));
    }
  }
  failAt(v, label, "must be a number or an expression string, got " + typeNameOf(v));
}

Expression TomlSection::expression(const std::string& key) const {
  return expressionOf(at(key), key);
}

VectorValue TomlSection::vector(const std::string& key) const {
  const toml::value& v = at(key);
  if (!v.is_array())
    fail(key, "must be an array of numbers or expression strings, got " + typeNameOf(v));
  VectorValue out;
  out.line = lineOf(v);
  const auto& a = v.as_array();
  if (a.empty() || a.size() > 3)
    fail(key, "= " + literalOf(v) + " must have 2 or 3 entries (one per coordinate), got " +
                  std::to_string(a.size()));
  for (std::size_t i = 0; i < a.size(); ++i)
    out.entries.push_back(expressionOf(a[i], key + "[" + std::to_string(i) + "]"));
  return out;
}

BoundaryRef TomlSection::boundary(const std::string& key) const {
  const toml::value& v = at(key);
  BoundaryRef ref;
  ref.line = lineOf(v);
  if (v.is_string()) {
    ref.name = v.as_string().str;
    if (ref.name.empty()) fail(key, "must not be empty");
    checkOneLine(*this, v, key);
  } else if (v.is_integer()) {
    if (v.as_integer() < 0 || v.as_integer() > 1'000'000'000)
      fail(key, "= " + literalOf(v) + " must be a boundary name or a non-negative boundary id");
    ref.id = static_cast<int>(v.as_integer());
  } else {
    fail(key, "must be a boundary name (string) or id (integer), got " + typeNameOf(v));
  }
  return ref;
}

std::vector<double> finiteNumberEntries(const TomlSection& s, const toml::value& v, const std::string& label) {
  const auto& a = v.as_array();
  std::vector<double> out;
  out.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].is_integer())
      out.push_back(static_cast<double>(a[i].as_integer()));
    else if (a[i].is_floating() && std::isfinite(a[i].as_floating()))
      out.push_back(a[i].as_floating());
    else
      s.failAt(a[i], label + "[" + std::to_string(i) + "]", "must be a finite number, got " + literalOf(a[i]));
  }
  return out;
}

}  // namespace obs::drivers

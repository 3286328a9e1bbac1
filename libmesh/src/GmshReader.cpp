/// \file GmshReader.cpp
/// readGmsh: a line-oriented parser for Gmsh .msh files, format 4.1 and 2.2, ASCII.
///
/// The file is read into memory and consumed one line at a time; each line is split into
/// whitespace-separated tokens, and every count, tag and number is checked before it is used, so
/// that malformed input ends in an obs::Error naming the file and line rather than in undefined
/// behaviour. Records are strictly one per line, as Gmsh writes them (one node tag per line and
/// one coordinate triple per line in 4.1, one element per line), which lets a wrong number of
/// node tags be reported on the line where it occurs. Blank lines are ignored everywhere.
///
/// The sections are first parsed into plain records (nodes, elements, entities, names) and the
/// Mesh is assembled at the end, so apart from $MeshFormat coming first the order of the
/// sections does not matter.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Gmsh.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/SurfaceMesh.hpp"

namespace obs::mesh {
namespace {

/// Node and element tags (size_t in the format specification; positive in practice).
using Tag = std::int64_t;

// ---------------------------------------------------------------------------------------------
// Element types

struct ElementInfo {
  int dim;       ///< topological dimension, 0 for points
  int numNodes;  ///< nodes per element
};

/// Dimension and node count of a Gmsh element type obs reads (1-7 and the point, 15).
std::optional<ElementInfo> supportedElement(int gmshType) {
  if (gmshType == 15) return ElementInfo{0, 1};
  if (const auto type = cellTypeFromGmsh(gmshType))
    return ElementInfo{dimension(*type), numVertices(*type)};
  return std::nullopt;
}

/// Short description of a supported element type for messages ("3-node triangle").
std::string describeSupported(int gmshType) {
  if (gmshType == 15) return "1-node point";
  const CellType type = *cellTypeFromGmsh(gmshType);
  return std::to_string(numVertices(type)) + "-node " + std::string(name(type));
}

/// Error text for an element type that obs does not read.
std::string unsupportedElementMessage(int gmshType) {
  std::string what;
  switch (gmshType) {
    case 8: what = " (3-node second-order line)"; break;
    case 9: what = " (6-node second-order triangle)"; break;
    case 10: what = " (9-node second-order quadrangle)"; break;
    case 11: what = " (10-node second-order tetrahedron)"; break;
    case 12: what = " (27-node second-order hexahedron)"; break;
    case 13: what = " (18-node second-order prism)"; break;
    case 14: what = " (14-node second-order pyramid)"; break;
    case 16: what = " (8-node second-order quadrangle)"; break;
    case 17: what = " (20-node second-order hexahedron)"; break;
    case 18: what = " (15-node second-order prism)"; break;
    case 19: what = " (13-node second-order pyramid)"; break;
    default:
      if (gmshType > 19) what = " (a higher-order or special element)";
      break;
  }
  return "unsupported element type " + std::to_string(gmshType) + what +
         "; only first-order elements are supported (types 1-7 and 15; mesh with "
         "Mesh.ElementOrder = 1)";
}

// ---------------------------------------------------------------------------------------------
// Line reader

/// A token or line quoted in an error message: at most 40 characters, non-printable bytes
/// (e.g. from a binary file) replaced by '?'.
std::string quoted(std::string_view text) {
  constexpr std::size_t maxLength = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < text.size() && i < maxLength; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (text.size() > maxLength) out += "...";
  return out + "'";
}

/// `text` as quoted() shortens it, without the quotes (for names and numbers inside a message).
std::string shortened(std::string_view text) {
  const std::string q = quoted(text);
  return q.substr(1, q.size() - 2);
}

constexpr bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/// Walks over the non-blank lines of a file held in memory, splits each into tokens and
/// converts tokens to numbers, throwing obs::Error with "file:line: ..." on any problem.
class LineReader {
public:
  LineReader(std::string text, std::string fileName)
      : text_(std::move(text)), fileName_(std::move(fileName)) {}

  /// Advances to the next non-blank line; false at the end of the file.
  bool next() {
    while (pos_ < text_.size()) {
      std::size_t end = text_.find('\n', pos_);
      if (end == std::string::npos) end = text_.size();
      const std::string_view line(text_.data() + pos_, end - pos_);
      pos_ = end + 1;
      ++lineNumber_;
      split(line);
      if (!tokens_.empty()) return true;
    }
    tokens_.clear();
    return false;
  }

  /// Advances to the next non-blank line, which must exist; otherwise fails with
  /// "unexpected end of file <context>".
  void require(std::string_view context) {
    if (!next()) fail("unexpected end of file " + std::string(context));
  }

  /// The current line without leading and trailing white space.
  std::string_view line() const { return line_; }
  std::size_t numTokens() const { return tokens_.size(); }
  std::string_view token(std::size_t i) const {
    if (i >= tokens_.size()) fail("too few values on this line");
    return tokens_[i];
  }
  /// Line number of the current line (1-based); at the end of the file, the last line.
  std::size_t lineNumber() const { return lineNumber_ == 0 ? 1 : lineNumber_; }

  /// Fails unless the current line has exactly n tokens.
  void expectTokens(std::size_t n, std::string_view what) const {
    if (tokens_.size() != n)
      fail("expected " + std::to_string(n) + (n == 1 ? " value" : " values") + " (" +
           std::string(what) + "), found " + std::to_string(tokens_.size()));
  }

  /// Token i as an integer of type Int (any value representable in Int).
  template <class Int>
  Int integer(std::size_t i, std::string_view what) const {
    const std::string_view tok = token(i);
    Int value{};
    const auto [end, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), value);
    if (ec == std::errc::result_out_of_range)
      fail(std::string(what) + " " + quoted(tok) + " is out of range");
    if (ec != std::errc() || end != tok.data() + tok.size())
      fail("expected an integer (" + std::string(what) + "), found " + quoted(tok));
    return value;
  }
  /// Token i as a count (non-negative integer).
  std::int64_t count(std::size_t i, std::string_view what) const {
    const auto value = integer<std::int64_t>(i, what);
    if (value < 0) fail(std::string(what) + " must not be negative, found " + quoted(token(i)));
    return value;
  }
  /// Token i as a node or element tag (positive integer).
  Tag tag(std::size_t i, std::string_view what) const {
    const auto value = integer<Tag>(i, what);
    if (value <= 0) fail(std::string(what) + " must be positive, found " + quoted(token(i)));
    return value;
  }
  /// Token i as a finite floating-point number.
  double real(std::size_t i, std::string_view what) const {
    std::string_view tok = token(i);
    std::string_view digits = tok;
    if (digits.size() > 1 && digits[0] == '+') digits.remove_prefix(1);  // from_chars rejects '+'
    double value = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (ec != std::errc() || end != digits.data() + digits.size())
      fail("expected a number (" + std::string(what) + "), found " + quoted(tok));
    if (!std::isfinite(value)) fail(std::string(what) + " must be finite, found " + quoted(tok));
    return value;
  }

  [[noreturn]] void fail(const std::string& message) const { failAt(lineNumber(), message); }
  [[noreturn]] void failAt(std::size_t line, const std::string& message) const {
    throw Error(fileName_ + ":" + std::to_string(line) + ": " + message);
  }

private:
  void split(std::string_view line) {
    tokens_.clear();
    std::size_t i = 0;
    while (true) {
      while (i < line.size() && isSpace(line[i])) ++i;
      if (i == line.size()) break;
      const std::size_t start = i;
      while (i < line.size() && !isSpace(line[i])) ++i;
      tokens_.push_back(line.substr(start, i - start));
    }
    if (!tokens_.empty()) {
      const char* first = tokens_.front().data();
      const char* last = tokens_.back().data() + tokens_.back().size();
      line_ = std::string_view(first, static_cast<std::size_t>(last - first));
    } else {
      line_ = {};
    }
  }

  std::string text_;
  std::string fileName_;
  std::size_t pos_ = 0;
  std::size_t lineNumber_ = 0;
  std::string_view line_;
  std::vector<std::string_view> tokens_;
};

// ---------------------------------------------------------------------------------------------
// Parser

/// One element as read from $Elements; node tags are kept in a flat array.
struct RawElement {
  int gmshType;
  int dim;
  Tag tag;
  std::size_t line;       ///< line of the element in the file
  std::size_t firstNode;  ///< offset into Parser::elementNodes_
  int numNodes;
  int physical;  ///< format 2.2: first tag (0: none)
  int block;     ///< format 4.1: index into Parser::blocks_; -1 for format 2.2
};

/// Header of an element block (format 4.1): the entity its elements belong to.
struct ElementBlock {
  int entityDim;
  int entityTag;
  std::size_t line;
};

using EntityKey = std::pair<int, int>;  ///< (dimension, tag) of a physical group or entity

class Parser {
public:
  explicit Parser(LineReader& in) : in_(in) {}

  Mesh parse() {
    parseSections();
    return assemble();
  }

  /// The Mesh of parse() with the physical groups of its cells (readGmshGroups).
  GmshMesh parseGroups() {
    parseSections();
    GmshMesh out;
    out.mesh = assemble(&out);
    return out;
  }

  SurfaceMesh parseSurface() {
    parseSections();
    return assembleSurface();
  }

private:
  void parseSections() {
    parseMeshFormat();
    while (in_.next()) {
      const std::string_view header = in_.line();
      if (header.front() != '$' || in_.numTokens() != 1)
        in_.fail("expected a section header such as $Nodes, found " + quoted(header));
      const std::string_view name = header.substr(1);
      if (name.starts_with("End"))
        in_.fail(quoted(header) + " without a matching $" + shortened(name.substr(3)));
      if (name == "MeshFormat")
        in_.fail("second $MeshFormat section");
      else if (name == "PhysicalNames")
        parsePhysicalNames();
      else if (name == "Entities" && v4_)
        parseEntities();
      else if (name == "PartitionedEntities" && v4_)
        in_.fail("partitioned meshes are not supported; save the mesh without partitions");
      else if (name == "Nodes")
        v4_ ? parseNodes41() : parseNodes22();
      else if (name == "Elements")
        v4_ ? parseElements41() : parseElements22();
      else
        skipSection(name);
    }
  }

  // --- sections ------------------------------------------------------------------------------

  /// "$MeshFormat / version file-type data-size / $EndMeshFormat" at the start of the file.
  void parseMeshFormat() {
    if (!in_.next()) in_.fail("empty file; expected $MeshFormat (not a Gmsh .msh file?)");
    if (in_.line() != "$MeshFormat")
      in_.fail("expected $MeshFormat at the start of the file, found " + quoted(in_.line()) +
               " (not a Gmsh .msh file?)");
    const std::size_t start = in_.lineNumber();
    in_.require(context("MeshFormat", start));
    in_.expectTokens(3, "version, file type, data size");
    const double version = in_.real(0, "format version");
    const auto fileType = in_.integer<int>(1, "file type");
    in_.integer<int>(2, "data size");
    if (version == 4.1)
      v4_ = true;
    else if (version == 2.2 || version == 2.1 || version == 2.0)
      v4_ = false;
    else
      in_.fail("unsupported .msh format version " + shortened(in_.token(0)) +
               " (readable: 4.1 and 2.2, ASCII)");
    if (fileType == 1)
      in_.fail(
          "binary .msh is not supported; save the mesh as ASCII (e.g. gmsh -format msh41, "
          "without -bin)");
    if (fileType != 0) in_.fail("invalid file type " + quoted(in_.token(1)) + " (0: ASCII)");
    expectEnd("MeshFormat", start);
  }

  /// "$PhysicalNames / count / dim tag "name" ... / $EndPhysicalNames".
  void parsePhysicalNames() {
    const std::size_t start = in_.lineNumber();
    const std::string ctx = context("PhysicalNames", start);
    in_.require(ctx);
    in_.expectTokens(1, "number of physical names");
    const std::int64_t n = in_.count(0, "number of physical names");
    for (std::int64_t i = 0; i < n; ++i) {
      in_.require(ctx);
      if (in_.numTokens() < 3) in_.fail("expected: dimension tag \"name\"");
      const int dim = in_.integer<int>(0, "physical dimension");
      const int tag = in_.integer<int>(1, "physical tag");
      if (dim < 0 || dim > 3)
        in_.fail("physical dimension must be 0-3, found " + quoted(in_.token(0)));
      // The name is the rest of the line in double quotes; it may contain spaces.
      const std::string_view line = in_.line();
      const std::string_view rest =
          line.substr(static_cast<std::size_t>(in_.token(2).data() - line.data()));
      if (rest.size() < 2 || rest.front() != '"' || rest.back() != '"')
        in_.fail("physical name must be in double quotes, found " + quoted(rest));
      physicalNames_[{dim, tag}] = std::string(rest.substr(1, rest.size() - 2));
    }
    expectEnd("PhysicalNames", start);
  }

  /// "$Entities" (format 4.1): the physical tags of every point, curve, surface and volume.
  /// Points:  tag x y z numPhysicalTags physicalTag...
  /// Others:  tag minX minY minZ maxX maxY maxZ numPhysicalTags physicalTag...
  ///          numBoundingEntities boundingTag...
  void parseEntities() {
    if (hasEntities_) in_.fail("second $Entities section");
    hasEntities_ = true;
    const std::size_t start = in_.lineNumber();
    const std::string ctx = context("Entities", start);
    in_.require(ctx);
    in_.expectTokens(4, "numbers of points, curves, surfaces, volumes");
    std::int64_t counts[4];
    for (int d = 0; d < 4; ++d)
      counts[d] = in_.count(static_cast<std::size_t>(d), "number of entities");
    for (int d = 0; d < 4; ++d) {
      for (std::int64_t i = 0; i < counts[d]; ++i) {
        in_.require(ctx);
        const std::size_t numCoords = d == 0 ? 3 : 6;  // point coordinates or bounding box
        const std::size_t physAt = 1 + numCoords;      // position of numPhysicalTags
        if (in_.numTokens() < physAt + 1) in_.fail("too few values for an entity");
        const int tag = in_.integer<int>(0, "entity tag");
        for (std::size_t k = 1; k < physAt; ++k) in_.real(k, "entity coordinate");
        const auto numPhys = static_cast<std::size_t>(in_.count(physAt, "number of physical tags"));
        if (numPhys > in_.numTokens() - physAt - 1) in_.fail("too few physical tags for an entity");
        std::vector<int> physicals;
        for (std::size_t k = 0; k < numPhys; ++k) {
          const int p = in_.integer<int>(physAt + 1 + k, "physical tag");
          if (std::find(physicals.begin(), physicals.end(), p) == physicals.end())
            physicals.push_back(p);
        }
        std::size_t expected = physAt + 1 + numPhys;
        if (d > 0) {  // bounding entities (signed tags); only checked
          const std::size_t boundAt = expected;
          if (in_.numTokens() <= boundAt) in_.fail("missing number of bounding entities");
          const auto numBound =
              static_cast<std::size_t>(in_.count(boundAt, "number of bounding entities"));
          if (numBound > in_.numTokens() - boundAt - 1) in_.fail("too few bounding entity tags");
          for (std::size_t k = 0; k < numBound; ++k)
            in_.integer<int>(boundAt + 1 + k, "bounding entity tag");
          expected = boundAt + 1 + numBound;
        }
        if (in_.numTokens() != expected)
          in_.fail("expected " + std::to_string(expected) + " values for this entity, found " +
                   std::to_string(in_.numTokens()));
        entities_[{d, tag}] = std::move(physicals);
      }
    }
    expectEnd("Entities", start);
  }

  /// "$Nodes" (format 4.1):
  ///   numEntityBlocks numNodes minNodeTag maxNodeTag
  ///   per block: entityDim entityTag parametric numNodesInBlock, then one tag per line, then one
  ///   "x y z [u [v [w]]]" per line (parametric coordinates, as many as entityDim, if parametric).
  void parseNodes41() {
    const std::size_t start = beginUniqueSection(nodesLine_, "Nodes");
    const std::string ctx = context("Nodes", start);
    in_.require(ctx);
    const std::size_t headerLine = in_.lineNumber();
    in_.expectTokens(4, "numEntityBlocks numNodes minNodeTag maxNodeTag");
    const std::int64_t numBlocks = in_.count(0, "number of node blocks");
    const std::int64_t numNodes = in_.count(1, "number of nodes");
    in_.count(2, "minimum node tag");
    in_.count(3, "maximum node tag");
    std::int64_t total = 0;
    std::vector<Tag> blockTags;
    for (std::int64_t b = 0; b < numBlocks; ++b) {
      in_.require(ctx);
      in_.expectTokens(4, "entityDim entityTag parametric numNodesInBlock");
      const int entityDim = in_.integer<int>(0, "entity dimension");
      in_.integer<int>(1, "entity tag");
      const int parametric = in_.integer<int>(2, "parametric flag");
      const std::int64_t n = in_.count(3, "number of nodes in block");
      if (entityDim < 0 || entityDim > 3) in_.fail("entity dimension must be 0-3");
      if (parametric != 0 && parametric != 1) in_.fail("parametric flag must be 0 or 1");
      const std::size_t numValues = 3 + (parametric ? static_cast<std::size_t>(entityDim) : 0);
      blockTags.clear();
      for (std::int64_t i = 0; i < n; ++i) {
        in_.require(ctx);
        in_.expectTokens(1, "one node tag per line");
        blockTags.push_back(in_.tag(0, "node tag"));
        nodeLines_.push_back(in_.lineNumber());
      }
      for (std::int64_t i = 0; i < n; ++i) {
        in_.require(ctx);
        in_.expectTokens(numValues, parametric ? "x y z and parametric coordinates" : "x y z");
        addNode(blockTags[static_cast<std::size_t>(i)], readPoint(),
                nodeLines_[nodeLines_.size() - static_cast<std::size_t>(n - i)]);
      }
      total += n;
    }
    if (total != numNodes)
      in_.failAt(headerLine, "the header announces " + std::to_string(numNodes) +
                                 " nodes, but the blocks hold " + std::to_string(total));
    expectEnd("Nodes", start);
  }

  /// "$Nodes" (format 2.2): count, then "tag x y z" per line.
  void parseNodes22() {
    const std::size_t start = beginUniqueSection(nodesLine_, "Nodes");
    const std::string ctx = context("Nodes", start);
    in_.require(ctx);
    in_.expectTokens(1, "number of nodes");
    const std::int64_t n = in_.count(0, "number of nodes");
    for (std::int64_t i = 0; i < n; ++i) {
      in_.require(ctx);
      in_.expectTokens(4, "node tag x y z");
      const Tag tag = in_.tag(0, "node tag");
      nodeLines_.push_back(in_.lineNumber());
      addNode(tag, readPoint(1), in_.lineNumber());
    }
    expectEnd("Nodes", start);
  }

  /// "$Elements" (format 4.1):
  ///   numEntityBlocks numElements minElementTag maxElementTag
  ///   per block: entityDim entityTag elementType numElementsInBlock, then "tag node..." per line.
  void parseElements41() {
    const std::size_t start = beginUniqueSection(elementsLine_, "Elements");
    const std::string ctx = context("Elements", start);
    in_.require(ctx);
    const std::size_t headerLine = in_.lineNumber();
    in_.expectTokens(4, "numEntityBlocks numElements minElementTag maxElementTag");
    const std::int64_t numBlocks = in_.count(0, "number of element blocks");
    const std::int64_t numElements = in_.count(1, "number of elements");
    in_.count(2, "minimum element tag");
    in_.count(3, "maximum element tag");
    std::int64_t total = 0;
    for (std::int64_t b = 0; b < numBlocks; ++b) {
      in_.require(ctx);
      in_.expectTokens(4, "entityDim entityTag elementType numElementsInBlock");
      const int entityDim = in_.integer<int>(0, "entity dimension");
      const int entityTag = in_.integer<int>(1, "entity tag");
      const int type = in_.integer<int>(2, "element type");
      const std::int64_t n = in_.count(3, "number of elements in block");
      const auto info = supportedElement(type);
      if (!info) in_.fail(unsupportedElementMessage(type));
      const int block = static_cast<int>(blocks_.size());
      blocks_.push_back({entityDim, entityTag, in_.lineNumber()});
      for (std::int64_t i = 0; i < n; ++i) {
        in_.require(ctx);
        const Tag tag = in_.tag(0, "element tag");
        checkNodeCount(tag, type, *info, in_.numTokens() - 1);
        addElement(tag, type, *info, 1, 0, block);
      }
      total += n;
    }
    if (total != numElements)
      in_.failAt(headerLine, "the header announces " + std::to_string(numElements) +
                                 " elements, but the blocks hold " + std::to_string(total));
    expectEnd("Elements", start);
  }

  /// "$Elements" (format 2.2): count, then "tag type numTags tag... node..." per line; the first
  /// tag is the physical group (0: none), the second the elementary entity.
  void parseElements22() {
    const std::size_t start = beginUniqueSection(elementsLine_, "Elements");
    const std::string ctx = context("Elements", start);
    in_.require(ctx);
    in_.expectTokens(1, "number of elements");
    const std::int64_t n = in_.count(0, "number of elements");
    for (std::int64_t i = 0; i < n; ++i) {
      in_.require(ctx);
      if (in_.numTokens() < 3) in_.fail("expected: element-tag type number-of-tags tags nodes");
      const Tag tag = in_.tag(0, "element tag");
      const int type = in_.integer<int>(1, "element type");
      const auto numTags = static_cast<std::size_t>(in_.count(2, "number of tags"));
      const auto info = supportedElement(type);
      if (!info) in_.fail(unsupportedElementMessage(type));
      if (numTags > in_.numTokens() - 3)
        in_.fail("element " + std::to_string(tag) + " announces " + std::to_string(numTags) +
                 " tags, but the line holds only " + std::to_string(in_.numTokens() - 3) +
                 " more values");
      for (std::size_t k = 0; k < numTags; ++k) in_.integer<int>(3 + k, "element tag value");
      const int physical = numTags > 0 ? in_.integer<int>(3, "physical tag") : 0;
      checkNodeCount(tag, type, *info, in_.numTokens() - 3 - numTags);
      addElement(tag, type, *info, 3 + numTags, physical, -1);
    }
    expectEnd("Elements", start);
  }

  /// Skips an unknown section up to its end marker.
  void skipSection(std::string_view name) {
    const std::size_t start = in_.lineNumber();
    const std::string end = "$End" + std::string(name);
    while (in_.next())
      if (in_.line() == end) return;
    // the name as quoted (at most 40 characters): an unknown section can be any line
    const std::string bare = shortened(name);
    in_.fail("unexpected end of file: missing $End" + bare + " (section $" + bare +
             " starts at line " + std::to_string(start) + ")");
  }

  // --- helpers -------------------------------------------------------------------------------

  static std::string context(std::string_view section, std::size_t start) {
    return "in $" + std::string(section) + " (section starts at line " + std::to_string(start) +
           ")";
  }

  /// Records the start line of a section that may occur only once.
  std::size_t beginUniqueSection(std::size_t& startLine, std::string_view name) {
    if (startLine != 0)
      in_.fail("second $" + std::string(name) + " section (the first starts at line " +
               std::to_string(startLine) + ")");
    startLine = in_.lineNumber();
    return startLine;
  }

  /// The next line must be "$End<name>".
  void expectEnd(std::string_view name, std::size_t start) {
    const std::string end = "$End" + std::string(name);
    if (!in_.next())
      in_.fail("unexpected end of file: missing " + end + " (section $" + std::string(name) +
               " starts at line " + std::to_string(start) + ")");
    if (in_.line() != end) in_.fail("expected " + end + ", found " + quoted(in_.line()));
  }

  /// x y z from tokens first..first+2 of the current line.
  Point readPoint(std::size_t first = 0) const {
    return {in_.real(first, "x coordinate"), in_.real(first + 1, "y coordinate"),
            in_.real(first + 2, "z coordinate")};
  }

  void addNode(Tag tag, const Point& x, std::size_t line) {
    const auto [it, inserted] = nodeIndex_.emplace(tag, nodeTags_.size());
    if (!inserted)
      in_.failAt(line, "duplicate node tag " + std::to_string(tag) + " (first defined at line " +
                           std::to_string(nodeLines_[it->second]) + ")");
    nodeTags_.push_back(tag);
    nodeCoords_.push_back(x);
  }

  void checkNodeCount(Tag tag, int type, const ElementInfo& info, std::size_t found) const {
    if (found != static_cast<std::size_t>(info.numNodes))
      in_.fail("element " + std::to_string(tag) + " of type " + std::to_string(type) + " (" +
               describeSupported(type) + ") has " + std::to_string(found) +
               " node tags, expected " + std::to_string(info.numNodes));
  }

  /// Records the element on the current line whose node tags start at token `firstToken`.
  void addElement(Tag tag, int type, const ElementInfo& info, std::size_t firstToken, int physical,
                  int block) {
    const std::size_t first = elementNodes_.size();
    for (int k = 0; k < info.numNodes; ++k)
      elementNodes_.push_back(in_.tag(firstToken + static_cast<std::size_t>(k), "node tag"));
    elements_.push_back(
        {type, info.dim, tag, in_.lineNumber(), first, info.numNodes, physical, block});
  }

  /// Position in nodeTags_ / nodeCoords_ of node k of element e (once assemble() has resolved
  /// the node tags).
  std::size_t node(const RawElement& e, int k) const {
    return static_cast<std::size_t>(elementNodes_[e.firstNode + static_cast<std::size_t>(k)]);
  }

  /// Physical tags of an element: from its entity (4.1) or its first tag (2.2).
  std::vector<int> physicalTags(const RawElement& e) const {
    if (e.block < 0) return e.physical != 0 ? std::vector<int>{e.physical} : std::vector<int>{};
    const ElementBlock& b = blocks_[static_cast<std::size_t>(e.block)];
    const auto it = entities_.find({b.entityDim, b.entityTag});
    return it != entities_.end() ? it->second : std::vector<int>{};
  }

  // --- assembly ------------------------------------------------------------------------------

  /// Checks the sections that must exist and replaces the node tags in elementNodes_ by node
  /// positions.
  void resolveNodes() {
    if (elementsLine_ == 0) in_.fail("no $Elements section");
    if (nodesLine_ == 0) in_.fail("no $Nodes section");
    if (nodeTags_.size() > static_cast<std::size_t>(std::numeric_limits<Index>::max()))
      in_.failAt(nodesLine_, "too many nodes");

    // Resolve node tags to node positions (in place) and check entity references.
    for (const RawElement& e : elements_)
      for (int k = 0; k < e.numNodes; ++k) {
        Tag& tag = elementNodes_[e.firstNode + static_cast<std::size_t>(k)];
        const auto it = nodeIndex_.find(tag);
        if (it == nodeIndex_.end())
          in_.failAt(e.line, "element " + std::to_string(e.tag) + " references unknown node " +
                                 std::to_string(tag));
        tag = static_cast<Tag>(it->second);
      }
    if (hasEntities_)
      for (const ElementBlock& b : blocks_)
        if (!entities_.contains({b.entityDim, b.entityTag}))
          in_.failAt(b.line, "element block refers to entity (dimension " +
                                 std::to_string(b.entityDim) + ", tag " +
                                 std::to_string(b.entityTag) + "), which $Entities does not list");
  }

  /// The Mesh (see Gmsh.hpp); with `groups`, also the physical tags of the cells and the list of
  /// physical groups (which do not change the Mesh).
  Mesh assemble(GmshMesh* groups = nullptr) {
    resolveNodes();
    int dim = 0;
    for (const RawElement& e : elements_) dim = std::max(dim, e.dim);
    if (dim < 2) in_.failAt(elementsLine_, "no cells: $Elements holds no 2D or 3D elements");

    // Vertices: the nodes used by cells, numbered in file order.
    std::vector<Index> vertexOf(nodeTags_.size(), -1);
    for (const RawElement& e : elements_)
      if (e.dim == dim)
        for (int k = 0; k < e.numNodes; ++k) vertexOf[node(e, k)] = 0;
    Mesh mesh(dim);
    for (std::size_t n = 0; n < nodeTags_.size(); ++n) {
      if (vertexOf[n] < 0) continue;
      Point x = nodeCoords_[n];
      if (dim == 2) x.z() = 0;
      vertexOf[n] = mesh.addVertex(x);
    }

    std::vector<Index> vertices;
    auto collect = [&](const RawElement& e) {
      vertices.clear();
      for (int k = 0; k < e.numNodes; ++k) vertices.push_back(vertexOf[node(e, k)]);
    };

    // Cells in file order.
    for (const RawElement& e : elements_)
      if (e.dim == dim) {
        collect(e);
        mesh.addCell(*cellTypeFromGmsh(e.gmshType), vertices);
        if (groups) {
          for (int p : physicalTags(e)) groups->cellGroupTags.push_back(p);
          groups->cellGroupOffsets.push_back(static_cast<Index>(groups->cellGroupTags.size()));
        }
      }

    // Boundary faces: elements of dimension dim - 1 in physical groups, one face per group.
    for (const RawElement& e : elements_) {
      if (e.dim != dim - 1) continue;
      const std::vector<int> physicals = physicalTags(e);
      if (physicals.empty()) continue;
      collect(e);
      for (int k = 0; k < e.numNodes; ++k)
        if (vertices[static_cast<std::size_t>(k)] < 0)
          in_.failAt(e.line, "boundary element " + std::to_string(e.tag) + " (physical group " +
                                 std::to_string(physicals.front()) + ") uses node " +
                                 std::to_string(nodeTags_[node(e, k)]) +
                                 ", which belongs to no cell");
      for (int id : physicals) mesh.addBoundaryFace(vertices, id);
    }

    for (const auto& [key, name] : physicalNames_)
      if (key.first == dim - 1) mesh.setBoundaryName(key.second, name);
    if (groups) listGroups(*groups);
    return mesh;
  }

  /// Every physical group of the file with its name and number of elements: the groups named in
  /// $PhysicalNames, listed by an entity (4.1) or used by an element (2.2).
  void listGroups(GmshMesh& out) const {
    std::map<EntityKey, Index> count;
    for (const auto& [key, name] : physicalNames_) count.emplace(key, 0);
    for (const auto& [entity, physicals] : entities_)
      for (int p : physicals) count.emplace(EntityKey{entity.first, p}, 0);
    for (const RawElement& e : elements_)
      for (int p : physicalTags(e)) ++count[{e.dim, p}];
    for (const auto& [key, n] : count) {
      const auto name = physicalNames_.find(key);
      out.groups.push_back(
          {key.first, key.second, name != physicalNames_.end() ? name->second : std::string(), n});
    }
  }

  /// The elements of the highest dimension as the faces of a surface mesh (SurfaceMesh.hpp).
  SurfaceMesh assembleSurface() {
    resolveNodes();
    int dim = 0;
    for (const RawElement& e : elements_) dim = std::max(dim, e.dim);
    if (dim == 3)
      in_.failAt(elementsLine_, "holds volume elements; a surface mesh has triangles or quadrilaterals (3D) "
                                "or segments (2D) only");
    if (dim < 1) in_.failAt(elementsLine_, "no faces: $Elements holds no segments, triangles or quadrilaterals");
    SurfaceMesh surface;
    surface.dimension = dim + 1;
    std::vector<Index> vertexOf(nodeTags_.size(), -1);
    for (const RawElement& e : elements_)
      if (e.dim == dim)
        for (int k = 0; k < e.numNodes; ++k) {
          const std::size_t n = node(e, k);
          if (vertexOf[n] >= 0) continue;
          const Point& x = nodeCoords_[n];
          if (dim == 1 && x.z() != 0)
            in_.failAt(e.line, "segment " + std::to_string(e.tag) + " uses node " + std::to_string(nodeTags_[n]) +
                                   " with z = " + std::to_string(x.z()) +
                                   "; the segments of a 2D surface lie in the plane z = 0");
          vertexOf[n] = static_cast<Index>(surface.vertices.size());
          surface.vertices.push_back(x);
        }
    for (const RawElement& e : elements_) {
      if (e.dim != dim) continue;
      std::array<Index, 4> face{-1, -1, -1, -1};
      for (int k = 0; k < e.numNodes; ++k) face[static_cast<std::size_t>(k)] = vertexOf[node(e, k)];
      surface.types.push_back(*cellTypeFromGmsh(e.gmshType));
      surface.faces.push_back(face);
    }
    return surface;
  }

  LineReader& in_;
  bool v4_ = false;
  bool hasEntities_ = false;
  std::size_t nodesLine_ = 0;     ///< start line of $Nodes (0: not seen)
  std::size_t elementsLine_ = 0;  ///< start line of $Elements (0: not seen)

  std::map<EntityKey, std::string> physicalNames_;
  std::map<EntityKey, std::vector<int>> entities_;  ///< physical tags of each entity

  std::vector<Tag> nodeTags_;
  std::vector<Point> nodeCoords_;
  std::vector<std::size_t> nodeLines_;  ///< line of each node's tag, in reading order
  std::unordered_map<Tag, std::size_t> nodeIndex_;

  std::vector<RawElement> elements_;
  std::vector<Tag> elementNodes_;
  std::vector<ElementBlock> blocks_;
};

}  // namespace

namespace {

/// The text of a .msh file, or an obs::Error naming what is wrong with the path.
std::string readMshText(const std::filesystem::path& file) {
  const std::string fileName = file.string();
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) throw Error(fileName + ": file not found");
  if (std::filesystem::is_directory(file, ec))
    throw Error(fileName + ": is a directory, not a .msh file");
  std::ifstream stream(file, std::ios::binary);
  if (!stream) throw Error(fileName + ": cannot open file");
  std::string text((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
  if (stream.bad()) throw Error(fileName + ": read error");
  return text;
}

}  // namespace

Mesh readGmsh(const std::filesystem::path& file) { return readGmshString(readMshText(file), file.string()); }

SurfaceMesh readGmshSurface(const std::filesystem::path& file) {
  return readGmshSurfaceString(readMshText(file), file.string());
}

SurfaceMesh readGmshSurfaceString(std::string text, const std::string& fileName) {
  LineReader lines(std::move(text), fileName);
  SurfaceMesh surface = Parser(lines).parseSurface();
  surface.source = fileName;
  return surface;
}

Mesh readGmshString(std::string text, const std::string& fileName) {
  LineReader lines(std::move(text), fileName);
  return Parser(lines).parse();
}

GmshMesh readGmshGroups(const std::filesystem::path& file) {
  return readGmshGroupsString(readMshText(file), file.string());
}

GmshMesh readGmshGroupsString(std::string text, const std::string& fileName) {
  LineReader lines(std::move(text), fileName);
  GmshMesh out = Parser(lines).parseGroups();
  out.fileName = fileName;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Cell groups

namespace {

std::string describeGroup(const GmshPhysicalGroup& g) {
  return std::to_string(g.tag) + (g.name.empty() ? "" : " \"" + g.name + "\"");
}

std::string dimensionWord(int dim) {
  static const char* const words[] = {"points", "curves", "surfaces", "volumes"};
  return std::to_string(dim) + " (" + words[dim] + ")";
}

}  // namespace

std::string GmshMesh::describeCellGroups() const {
  std::string out;
  for (const GmshPhysicalGroup& g : groups)
    if (g.dimension == mesh.dimension())
      out += (out.empty() ? "" : ", ") + describeGroup(g) + " (" + std::to_string(g.elements) +
             (g.elements == 1 ? " cell)" : " cells)");
  return out.empty() ? "none" : out;
}

namespace {

/// The checks shared by both cellGroup overloads once a group of the mesh dimension is found.
const GmshPhysicalGroup& nonEmpty(const GmshMesh& file, const GmshPhysicalGroup& g) {
  if (g.elements == 0)
    throw Error(file.fileName + ": physical group " + describeGroup(g) + " (dimension " +
                std::to_string(g.dimension) + ") holds no cells (cell groups: " +
                file.describeCellGroups() + ")");
  return g;
}

}  // namespace

const GmshPhysicalGroup& GmshMesh::cellGroup(int tag) const {
  const int dim = mesh.dimension();
  std::string others;
  for (const GmshPhysicalGroup& g : groups) {
    if (g.tag != tag) continue;
    if (g.dimension == dim) return nonEmpty(*this, g);
    others += (others.empty() ? "" : ", ") + std::to_string(g.dimension);
  }
  if (!others.empty())
    throw Error(fileName + ": physical tag " + std::to_string(tag) + " is a group of dimension " +
                others + " only, not of the mesh dimension " + std::to_string(dim) +
                ": it holds no cells (cell groups of dimension " + dimensionWord(dim) +
                ": " + describeCellGroups() + ")");
  throw Error(fileName + ": no physical group of dimension " + dimensionWord(dim) +
              " with tag " + std::to_string(tag) + " (cell groups: " + describeCellGroups() + ")");
}

const GmshPhysicalGroup& GmshMesh::cellGroup(const std::string& name) const {
  const int dim = mesh.dimension();
  const GmshPhysicalGroup* found = nullptr;
  const GmshPhysicalGroup* other = nullptr;
  for (const GmshPhysicalGroup& g : groups) {
    if (g.name != name) continue;
    if (g.dimension != dim) {
      if (!other) other = &g;
      continue;
    }
    if (found)
      throw Error(fileName + ": the name \"" + name + "\" belongs to two physical groups of dimension " +
                  std::to_string(dim) + " (tags " + std::to_string(found->tag) + " and " +
                  std::to_string(g.tag) + "); select the group by its tag");
    found = &g;
  }
  if (found) return nonEmpty(*this, *found);
  if (other)
    throw Error(fileName + ": physical group \"" + name + "\" (tag " + std::to_string(other->tag) +
                ") has dimension " + std::to_string(other->dimension) + ", not the mesh dimension " +
                std::to_string(dim) + ": it holds no cells (cell groups of dimension " +
                dimensionWord(dim) + ": " + describeCellGroups() + ")");
  throw Error(fileName + ": no physical group named \"" + name + "\" (cell groups of dimension " +
              dimensionWord(dim) + ": " + describeCellGroups() + ")");
}

Mesh extractCellGroup(const GmshMesh& file, const std::string& name) {
  return extractCellGroup(file, file.cellGroup(name).tag);
}

Mesh extractCellGroup(const GmshMesh& file, int tag) {
  file.cellGroup(tag);  // throws for an unknown, lower-dimensional or empty group
  const Mesh& all = file.mesh;
  const int dim = all.dimension();
  std::vector<char> selected(static_cast<std::size_t>(all.numCells()), 0);
  std::vector<Index> vertexOf(static_cast<std::size_t>(all.numVertices()), -1);
  for (Index c = 0; c < all.numCells(); ++c) {
    const auto tags = file.cellGroups(c);
    if (std::find(tags.begin(), tags.end(), tag) == tags.end()) continue;
    selected[static_cast<std::size_t>(c)] = 1;
    for (Index v : all.cellVertices(c)) vertexOf[static_cast<std::size_t>(v)] = 0;
  }
  Mesh body(dim);
  for (Index v = 0; v < all.numVertices(); ++v)
    if (vertexOf[static_cast<std::size_t>(v)] >= 0)
      vertexOf[static_cast<std::size_t>(v)] = body.addVertex(all.vertex(v));
  std::vector<Index> vertices;
  auto map = [&](std::span<const Index> in) {
    vertices.clear();
    for (Index v : in) vertices.push_back(vertexOf[static_cast<std::size_t>(v)]);
  };
  for (Index c = 0; c < all.numCells(); ++c)
    if (selected[static_cast<std::size_t>(c)]) {
      map(all.cellVertices(c));
      body.addCell(all.cellType(c), vertices);
    }
  // Boundary faces of the file that are faces of the body's cells, with their ids and names.
  const FaceTable faces(body);
  std::map<int, std::string> names;
  for (Index f = 0; f < all.numBoundaryFaces(); ++f) {
    map(all.boundaryFaceVertices(f));
    if (std::find(vertices.begin(), vertices.end(), Index{-1}) != vertices.end()) continue;
    if (faces.find(vertices) < 0) continue;
    const int id = all.boundaryFaceId(f);
    body.addBoundaryFace(vertices, id);
    if (const auto it = all.boundaryNames().find(id); it != all.boundaryNames().end())
      names.emplace(id, it->second);
  }
  for (const auto& [id, name] : names) body.setBoundaryName(id, name);
  return body;
}

}  // namespace obs::mesh

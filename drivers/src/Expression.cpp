#include "obs/drivers/Expression.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <memory>
#include <numbers>

namespace obs::drivers {

namespace {

using Op = Expression::Op;
using Instruction = Expression::Instruction;

constexpr int kMaxNesting = 200;
/// Longest chain of operations in the syntax tree (a + b + c + ... nests to the left without
/// parentheses); emitting and freeing the tree recurse along it, so it must stay far below what
/// the stack holds.
constexpr int kMaxChain = 10000;
constexpr int kInlineStack = 32;

int arity(Op op) {
  if (op <= Op::T) return 0;
  if (op <= Op::Ceil) return 1;
  return 2;
}

double apply(Op op, double a, double b) {
  switch (op) {
    case Op::Neg:
      return -a;
    case Op::Sin:
      return std::sin(a);
    case Op::Cos:
      return std::cos(a);
    case Op::Tan:
      return std::tan(a);
    case Op::Asin:
      return std::asin(a);
    case Op::Acos:
      return std::acos(a);
    case Op::Atan:
      return std::atan(a);
    case Op::Sinh:
      return std::sinh(a);
    case Op::Cosh:
      return std::cosh(a);
    case Op::Tanh:
      return std::tanh(a);
    case Op::Exp:
      return std::exp(a);
    case Op::Log:
      return std::log(a);
    case Op::Sqrt:
      return std::sqrt(a);
    case Op::Abs:
      return std::abs(a);
    case Op::Floor:
      return std::floor(a);
    case Op::Ceil:
      return std::ceil(a);
    case Op::Add:
      return a + b;
    case Op::Sub:
      return a - b;
    case Op::Mul:
      return a * b;
    case Op::Div:
      return a / b;
    case Op::Pow:
      return std::pow(a, b);
    case Op::Min:
      return std::min(a, b);
    case Op::Max:
      return std::max(a, b);
    case Op::Atan2:
      return std::atan2(a, b);
    default:
      return 0.0;  // push instructions are handled by the caller
  }
}

struct Function {
  std::string_view name;
  Op op;
};
constexpr std::array<Function, 19> kFunctions{{
    {"sin", Op::Sin},   {"cos", Op::Cos},     {"tan", Op::Tan},     {"asin", Op::Asin},
    {"acos", Op::Acos}, {"atan", Op::Atan},   {"sinh", Op::Sinh},   {"cosh", Op::Cosh},
    {"tanh", Op::Tanh}, {"exp", Op::Exp},     {"log", Op::Log},     {"sqrt", Op::Sqrt},
    {"abs", Op::Abs},   {"floor", Op::Floor}, {"ceil", Op::Ceil},   {"min", Op::Min},
    {"max", Op::Max},   {"pow", Op::Pow},     {"atan2", Op::Atan2},
}};

/// Syntax tree node; constant subtrees are folded while parsing.
struct Node {
  Op op = Op::Constant;
  double value = 0.0;
  int depth = 1;  ///< levels of the subtree
  std::unique_ptr<Node> a, b;
};
using NodePtr = std::unique_ptr<Node>;

NodePtr constant(double v) {
  auto n = std::make_unique<Node>();
  n->value = v;
  return n;
}

NodePtr combine(Op op, NodePtr a, NodePtr b = nullptr) {
  const bool foldable = a->op == Op::Constant && (!b || b->op == Op::Constant);
  if (foldable) return constant(apply(op, a->value, b ? b->value : 0.0));
  auto n = std::make_unique<Node>();
  n->op = op;
  n->depth = 1 + std::max(a->depth, b ? b->depth : 0);
  n->a = std::move(a);
  n->b = std::move(b);
  return n;
}

class Parser {
public:
  explicit Parser(std::string_view text) : s_(text) {}

  NodePtr parseAll() {
    skipSpace();
    if (pos_ == s_.size()) fail(pos_, "empty expression");
    NodePtr n = expression();
    skipSpace();
    if (pos_ != s_.size()) {
      if (s_[pos_] == ')') fail(pos_, "unmatched ')'");
      fail(pos_, "unexpected '" + std::string(1, s_[pos_]) + "' (missing operator?)");
    }
    return n;
  }

private:
  [[noreturn]] void fail(std::size_t pos, const std::string& reason) const {
    throw ExpressionError(std::string(s_), static_cast<int>(pos) + 1, reason);
  }

  void checkChain(const Node& n) const {
    if (n.depth > kMaxChain)
      fail(pos_, "expression too long: more than " + std::to_string(kMaxChain) +
                     " chained operations");
  }

  void skipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  bool accept(char c) {
    skipSpace();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }

  NodePtr expression() {
    if (++depth_ > kMaxNesting) fail(pos_, "expression nested too deeply");
    NodePtr n = term();
    for (;;) {
      if (accept('+'))
        n = combine(Op::Add, std::move(n), term());
      else if (accept('-'))
        n = combine(Op::Sub, std::move(n), term());
      else
        break;
      checkChain(*n);
    }
    --depth_;
    return n;
  }

  NodePtr term() {
    NodePtr n = unary();
    for (;;) {
      if (accept('*'))
        n = combine(Op::Mul, std::move(n), unary());
      else if (accept('/'))
        n = combine(Op::Div, std::move(n), unary());
      else
        break;
      checkChain(*n);
    }
    return n;
  }

  NodePtr unary() {
    if (++depth_ > kMaxNesting) fail(pos_, "expression nested too deeply");
    NodePtr n;
    if (accept('-'))
      n = combine(Op::Neg, unary());
    else if (accept('+'))
      n = unary();
    else
      n = power();
    --depth_;
    return n;
  }

  NodePtr power() {
    NodePtr base = primary();
    if (accept('^')) return combine(Op::Pow, std::move(base), unary());
    return base;
  }

  NodePtr primary() {
    skipSpace();
    const std::size_t start = pos_;
    if (pos_ == s_.size())
      fail(pos_, "unexpected end, expected a number, variable, function or '('");
    const char c = s_[pos_];
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') return number();
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      while (pos_ < s_.size() &&
             (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_'))
        ++pos_;
      return identifier(s_.substr(start, pos_ - start), start);
    }
    if (accept('(')) {
      NodePtr n = expression();
      if (!accept(')'))
        fail(pos_, "expected ')' to close '(' at position " + std::to_string(start + 1));
      return n;
    }
    fail(pos_,
         "unexpected '" + std::string(1, c) + "', expected a number, variable, function or '('");
  }

  NodePtr number() {
    const std::size_t start = pos_;
    auto digits = [&] {
      std::size_t n = 0;
      while (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) ++pos_, ++n;
      return n;
    };
    std::size_t n = digits();
    if (pos_ < s_.size() && s_[pos_] == '.') {
      ++pos_;
      n += digits();
    }
    if (n == 0) fail(start, "malformed number");
    if (pos_ < s_.size() && (s_[pos_] == 'e' || s_[pos_] == 'E')) {
      ++pos_;
      if (pos_ < s_.size() && (s_[pos_] == '+' || s_[pos_] == '-')) ++pos_;
      if (digits() == 0)
        fail(start, "malformed number '" + std::string(s_.substr(start, pos_ - start)) + "'");
    }
    double v = 0.0;
    const auto [end, ec] = std::from_chars(s_.data() + start, s_.data() + pos_, v);
    if (ec != std::errc() || end != s_.data() + pos_)
      fail(start, "number '" + std::string(s_.substr(start, pos_ - start)) + "' out of range");
    return constant(v);
  }

  NodePtr identifier(std::string_view name, std::size_t start) {
    skipSpace();
    const bool call = pos_ < s_.size() && s_[pos_] == '(';
    if (!call) {
      auto variable = [](Op op) {
        auto n = std::make_unique<Node>();
        n->op = op;
        return n;
      };
      if (name == "x") return variable(Op::X);
      if (name == "y") return variable(Op::Y);
      if (name == "z") return variable(Op::Z);
      if (name == "t") return variable(Op::T);
      if (name == "pi") return constant(std::numbers::pi);
      for (const auto& f : kFunctions)
        if (f.name == name)
          fail(pos_, "function '" + std::string(name) + "' needs '(' and arguments");
      fail(start, "unknown variable '" + std::string(name) + "' (variables: x, y, z, t, pi)");
    }
    const Function* fn = nullptr;
    for (const auto& f : kFunctions)
      if (f.name == name) fn = &f;
    if (!fn)
      fail(start, "unknown function '" + std::string(name) +
                      "' (functions: sin cos tan asin acos atan sinh cosh tanh exp log sqrt abs "
                      "floor ceil min max pow atan2)");
    accept('(');
    const int expected = arity(fn->op);
    std::vector<NodePtr> args;
    if (!accept(')')) {
      do args.push_back(expression());
      while (accept(','));
      if (!accept(')'))
        fail(pos_, "expected ',' or ')' in the arguments of '" + std::string(name) + "'");
    }
    if (static_cast<int>(args.size()) != expected)
      fail(start, "function '" + std::string(name) + "' takes " + std::to_string(expected) +
                      " argument" + (expected == 1 ? "" : "s") + ", got " +
                      std::to_string(args.size()));
    return expected == 1 ? combine(fn->op, std::move(args[0]))
                         : combine(fn->op, std::move(args[0]), std::move(args[1]));
  }

  std::string_view s_;
  std::size_t pos_ = 0;
  int depth_ = 0;
};

/// Appends the postfix code of `n`; returns the stack depth it needs.
int emit(const Node& n, std::vector<Instruction>& code) {
  int depth = 1;
  if (n.a) depth = emit(*n.a, code);
  if (n.b) depth = std::max(depth, 1 + emit(*n.b, code));
  code.push_back({n.op, n.value});
  return depth;
}

std::string shortest(double v) {
  std::array<char, 32> buf{};
  const auto r = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  return std::string(buf.data(), r.ptr);
}

}  // namespace

namespace {

/// `text` with every byte outside printable ASCII (line breaks, tabs, NUL, UTF-8) shown as '?'.
std::string printable(std::string_view text) {
  std::string out(text);
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
  return out;
}

/// At most about `width` characters of `text` around the 1-based `position`, "..." marking cuts.
std::string shortened(std::string_view text, int position, std::size_t width) {
  if (text.size() <= width) return printable(text);
  const std::size_t at = static_cast<std::size_t>(std::max(position, 1) - 1);
  const std::size_t begin = std::min(at > width / 2 ? at - width / 2 : 0, text.size() - width);
  return (begin > 0 ? "..." : "") + printable(text.substr(begin, width)) +
         (begin + width < text.size() ? "..." : "");
}

constexpr std::size_t kExcerptWidth = 80;

}  // namespace

ExpressionError::ExpressionError(std::string text, int position, std::string reason)
    : Error("expression \"" + shortened(text, position, kExcerptWidth) +
            "\": " + shortened(reason, 1, 2 * kExcerptWidth) + " at position " +
            std::to_string(position)),
      text_(std::move(text)),
      position_(position),
      reason_(shortened(reason, 1, 2 * kExcerptWidth)) {}

std::string ExpressionError::excerpt() const { return shortened(text_, position_, kExcerptWidth); }

Expression::Expression(double constant)
    : text_(shortest(constant)), code_{{Op::Constant, constant}}, stackSize_(1) {}

Expression::Expression(std::string text, std::vector<Instruction> code, int stackSize)
    : text_(std::move(text)), code_(std::move(code)), stackSize_(stackSize) {}

Expression Expression::parse(std::string_view text) {
  Parser parser(text);
  NodePtr root = parser.parseAll();
  std::vector<Instruction> code;
  const int depth = emit(*root, code);
  return Expression(std::string(text), std::move(code), depth);
}

double Expression::operator()(double x, double y, double z, double t) const {
  std::array<double, kInlineStack> inlineStack{};
  std::vector<double> heapStack;
  double* stack = inlineStack.data();
  if (stackSize_ > kInlineStack) {
    heapStack.resize(stackSize_);
    stack = heapStack.data();
  }
  int top = -1;
  for (const Instruction& in : code_) {
    switch (in.op) {
      case Op::Constant:
        stack[++top] = in.value;
        break;
      case Op::X:
        stack[++top] = x;
        break;
      case Op::Y:
        stack[++top] = y;
        break;
      case Op::Z:
        stack[++top] = z;
        break;
      case Op::T:
        stack[++top] = t;
        break;
      default:
        if (arity(in.op) == 1) {
          stack[top] = apply(in.op, stack[top], 0.0);
        } else {
          stack[top - 1] = apply(in.op, stack[top - 1], stack[top]);
          --top;
        }
    }
  }
  return stack[0];
}

}  // namespace obs::drivers

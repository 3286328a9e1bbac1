#pragma once
/// \file Expression.hpp
/// Scalar expressions of the position (x, y, z) and time t, as written in scene files, e.g.
/// "0.01*x", "-1e3 * sin(pi*x/4)", "max(0, 1 - (x^2 + y^2))".
///
/// Grammar (recursive descent, usual precedence, `^` binds tighter than unary minus and is right
/// associative: -2^2 = -4, 2^3^2 = 512):
///   expression := term { ('+' | '-') term }
///   term       := unary { ('*' | '/') unary }
///   unary      := ('-' | '+') unary | power
///   power      := primary [ '^' unary ]
///   primary    := number | 'x' | 'y' | 'z' | 't' | 'pi' | function '(' arguments ')' | '('
///   expression ')'
/// Functions: sin cos tan asin acos atan sinh cosh tanh exp log sqrt abs floor ceil (one argument),
/// min max pow atan2 (two arguments). Numbers: 2, 2.5, .5, 1e-3, 2.5E+4.
///
/// An expression is parsed once into postfix code (constant subexpressions folded) and evaluated on
/// a small fixed stack, so evaluating it at every quadrature point is cheap and thread-safe.
#include <Eigen/Core>

#include <string>
#include <string_view>
#include <vector>

#include "obs/mesh/Error.hpp"

namespace obs::drivers {

/// A syntax error in an expression. `position` is the 1-based character position in the text,
/// `reason` the bare description ("unknown function 'sinn'"); what() combines both with the text.
/// Messages stay one line of bounded length whatever the text holds: what(), excerpt() and
/// reason() show line breaks and other control bytes as '?' and shorten long texts around the
/// position (text() keeps the text as given).
class ExpressionError : public Error {
public:
  ExpressionError(std::string text, int position, std::string reason);
  const std::string& text() const { return text_; }
  int position() const { return position_; }
  const std::string& reason() const { return reason_; }
  /// The text as quoted in messages: printable, at most about 80 characters around the position.
  std::string excerpt() const;

private:
  std::string text_;
  int position_;
  std::string reason_;
};

class Expression {
public:
  /// The constant 0.
  Expression() : Expression(0.0) {}
  /// A constant; text() is the shortest decimal representation of the value.
  explicit Expression(double constant);

  /// Parses `text`; throws ExpressionError on a syntax error.
  static Expression parse(std::string_view text);

  double operator()(double x, double y, double z, double t = 0.0) const;
  double operator()(const Eigen::Vector3d& p, double t = 0.0) const {
    return (*this)(p[0], p[1], p[2], t);
  }

  /// True if the expression does not depend on x, y, z or t (then value() is its value).
  bool isConstant() const { return code_.size() == 1 && code_[0].op == Op::Constant; }
  double value() const { return (*this)(0.0, 0.0, 0.0, 0.0); }
  /// The source text (for constants built from a number, its decimal form).
  const std::string& text() const { return text_; }

  /// Instructions of the postfix code. The order matters: pushes, then unary, then binary ops.
  // clang-format off
  enum class Op : unsigned char {
    Constant, X, Y, Z, T,                                              // push
    Neg, Sin, Cos, Tan, Asin, Acos, Atan, Sinh, Cosh, Tanh, Exp, Log,  // unary
    Sqrt, Abs, Floor, Ceil,
    Add, Sub, Mul, Div, Pow, Min, Max, Atan2,                          // binary
  };
  // clang-format on
  struct Instruction {
    Op op;
    double value = 0.0;  ///< for Op::Constant
  };

private:
  Expression(std::string text, std::vector<Instruction> code, int stackSize);

  std::string text_;
  std::vector<Instruction> code_;
  int stackSize_ = 1;
};

}  // namespace obs::drivers

// Expression evaluator of scene files: values, precedence, functions, constant folding, errors
// with positions.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "obs/drivers/Expression.hpp"

using obs::drivers::Expression;
using obs::drivers::ExpressionError;

namespace {

double eval(const char* text, double x = 0, double y = 0, double z = 0, double t = 0) {
  return Expression::parse(text)(x, y, z, t);
}

int errorPosition(const char* text) {
  try {
    Expression::parse(text);
  } catch (const ExpressionError& e) {
    return e.position();
  }
  return -1;
}

}  // namespace

TEST(Expression, Numbers) {
  EXPECT_DOUBLE_EQ(eval("2"), 2.0);
  EXPECT_DOUBLE_EQ(eval("2.5"), 2.5);
  EXPECT_DOUBLE_EQ(eval(".5"), 0.5);
  EXPECT_DOUBLE_EQ(eval("1e-3"), 1e-3);
  EXPECT_DOUBLE_EQ(eval("2.5E+4"), 2.5e4);
  EXPECT_DOUBLE_EQ(eval("  7  "), 7.0);
}

TEST(Expression, Variables) {
  EXPECT_DOUBLE_EQ(eval("x", 1, 2, 3, 4), 1.0);
  EXPECT_DOUBLE_EQ(eval("y", 1, 2, 3, 4), 2.0);
  EXPECT_DOUBLE_EQ(eval("z", 1, 2, 3, 4), 3.0);
  EXPECT_DOUBLE_EQ(eval("t", 1, 2, 3, 4), 4.0);
  EXPECT_DOUBLE_EQ(eval("pi"), std::numbers::pi);
  EXPECT_DOUBLE_EQ(eval("0.01*x", 3.0), 0.03);
  const Expression e = Expression::parse("x + 10*y + 100*z");
  EXPECT_DOUBLE_EQ(e(Eigen::Vector3d(1, 2, 3)), 321.0);
}

TEST(Expression, Precedence) {
  EXPECT_DOUBLE_EQ(eval("1 + 2 * 3"), 7.0);
  EXPECT_DOUBLE_EQ(eval("(1 + 2) * 3"), 9.0);
  EXPECT_DOUBLE_EQ(eval("8 / 4 / 2"), 1.0);  // left associative
  EXPECT_DOUBLE_EQ(eval("8 - 4 - 2"), 2.0);
  EXPECT_DOUBLE_EQ(eval("2 ^ 3 ^ 2"), 512.0);  // right associative
  EXPECT_DOUBLE_EQ(eval("-2 ^ 2"), -4.0);      // ^ binds tighter than unary minus
  EXPECT_DOUBLE_EQ(eval("2 ^ -1"), 0.5);
  EXPECT_DOUBLE_EQ(eval("--3"), 3.0);
  EXPECT_DOUBLE_EQ(eval("-x * 2", 3.0), -6.0);
  EXPECT_DOUBLE_EQ(eval("2 * 3 ^ 2"), 18.0);
  EXPECT_DOUBLE_EQ(eval("+4 - -1"), 5.0);
}

TEST(Expression, Functions) {
  EXPECT_NEAR(eval("sin(pi/2)"), 1.0, 1e-15);
  EXPECT_NEAR(eval("cos(0)"), 1.0, 1e-15);
  EXPECT_NEAR(eval("tan(pi/4)"), 1.0, 1e-15);
  EXPECT_NEAR(eval("exp(log(3))"), 3.0, 1e-14);
  EXPECT_DOUBLE_EQ(eval("sqrt(16)"), 4.0);
  EXPECT_DOUBLE_EQ(eval("abs(-2.5)"), 2.5);
  EXPECT_DOUBLE_EQ(eval("min(3, -1)"), -1.0);
  EXPECT_DOUBLE_EQ(eval("max(3, -1)"), 3.0);
  EXPECT_DOUBLE_EQ(eval("pow(2, 10)"), 1024.0);
  EXPECT_NEAR(eval("atan2(1, 1)"), std::numbers::pi / 4, 1e-15);
  EXPECT_DOUBLE_EQ(eval("max(0, 1 - (x^2 + y^2))", 0.5, 0.5), 0.5);
  EXPECT_NEAR(eval("-1e3 * sin(pi*x/4)", 2.0), -1000.0, 1e-9);
}

TEST(Expression, ConstantsAreFolded) {
  const Expression c = Expression::parse("2 * pi * sin(pi / 6)");
  EXPECT_TRUE(c.isConstant());
  EXPECT_NEAR(c.value(), std::numbers::pi, 1e-14);
  EXPECT_FALSE(Expression::parse("2 * x").isConstant());
  EXPECT_FALSE(Expression::parse("t").isConstant());
  EXPECT_TRUE(Expression(1.5).isConstant());
  EXPECT_EQ(Expression(1.5).text(), "1.5");
  EXPECT_EQ(Expression::parse("0.01*x").text(), "0.01*x");
  EXPECT_EQ(Expression().value(), 0.0);
}

TEST(Expression, DeepExpressionsEvaluate) {
  // a right-leaning sum needs a deep stack (beyond the inline stack of the evaluator)
  std::string s;
  for (int i = 0; i < 60; ++i) s += "x+(";
  s += "x";
  for (int i = 0; i < 60; ++i) s += ")";
  EXPECT_DOUBLE_EQ(Expression::parse(s)(1, 0, 0), 61.0);
}

TEST(Expression, ErrorsGivePositions) {
  EXPECT_EQ(errorPosition("0.01*x+"), 8);  // unexpected end
  EXPECT_EQ(errorPosition("1 + foo"), 5);  // unknown variable
  EXPECT_EQ(errorPosition("sinn(x)"), 1);  // unknown function
  EXPECT_EQ(errorPosition("(1 + 2"), 7);   // missing ')'
  EXPECT_EQ(errorPosition("1 + 2)"), 6);   // unmatched ')'
  EXPECT_EQ(errorPosition("2 x"), 3);      // missing operator
  EXPECT_EQ(errorPosition("1 $ 2"), 3);    // bad character
  EXPECT_EQ(errorPosition(""), 1);         // empty
  EXPECT_EQ(errorPosition("1e"), 1);       // malformed number
  EXPECT_EQ(errorPosition("max(1)"), 1);   // wrong argument count
  EXPECT_EQ(errorPosition("sin(1, 2)"), 1);
  EXPECT_EQ(errorPosition("sin"), 4);  // function without arguments
  EXPECT_EQ(errorPosition("x * * y"), 5);
}

TEST(Expression, ErrorMessages) {
  try {
    Expression::parse("0.01*x+");
    FAIL() << "no error";
  } catch (const ExpressionError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("\"0.01*x+\""), std::string::npos) << msg;
    EXPECT_NE(msg.find("position 8"), std::string::npos) << msg;
    EXPECT_EQ(e.text(), "0.01*x+");
  }
  try {
    Expression::parse("sinn(x)");
    FAIL() << "no error";
  } catch (const obs::Error& e) {  // ExpressionError is an obs::Error
    EXPECT_NE(std::string(e.what()).find("unknown function 'sinn'"), std::string::npos) << e.what();
  }
  try {
    Expression::parse("a + 1");
    FAIL() << "no error";
  } catch (const ExpressionError& e) {
    EXPECT_NE(e.reason().find("unknown variable 'a'"), std::string::npos) << e.reason();
  }
}

TEST(Expression, NonFiniteValuesAreReturnedNotHidden) {
  EXPECT_TRUE(std::isnan(eval("sqrt(-1)")));
  EXPECT_TRUE(std::isinf(eval("1/x", 0.0)));
}

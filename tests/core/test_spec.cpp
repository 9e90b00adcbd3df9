#include <gtest/gtest.h>

#include "voxpack/core/errors.hpp"
#include "voxpack/core/spec.hpp"

using namespace voxpack;

TEST(Spec, ParsesKeysAndPositional) {
  const auto s = parseSpec("mesh:part.stl,scale=2", "shape");
  EXPECT_EQ(s.name, "mesh");
  ASSERT_TRUE(s.positional);
  EXPECT_EQ(*s.positional, "part.stl");
  EXPECT_DOUBLE_EQ(s.positive("scale"), 2.0);
  const auto c = parseSpec("cylinder:d=5.4,l=3.8", "shape");
  EXPECT_DOUBLE_EQ(c.positive("d"), 5.4);
  EXPECT_DOUBLE_EQ(c.positive("l"), 3.8);
}

TEST(Spec, RejectsBadValues) {
  EXPECT_THROW(parseSpec(":d=1", "shape"), InputError);
  EXPECT_THROW(parseSpec("sphere:d=1,d=2", "shape"), InputError);
  EXPECT_THROW(parseSpec("sphere:d=-1", "shape").positive("d"), InputError);
  EXPECT_THROW(parseSpec("sphere:d=abc", "shape").positive("d"), InputError);
  EXPECT_THROW(parseSpec("sphere:d=nan", "shape").positive("d"), InputError);
  EXPECT_THROW(parseSpec("sphere", "shape").positive("d"), InputError);
  EXPECT_THROW(parseSpec("sphere:d=1,q=2", "shape").allowOnly({"d"}), InputError);
}

TEST(Spec, NumberList) {
  const auto v = parseNumberList("1,0,0,0", 4, "orientation");
  EXPECT_EQ(v.size(), 4u);
  EXPECT_THROW(parseNumberList("1,0,0", 4, "orientation"), InputError);
  EXPECT_THROW(parseNumberList("1,x,0,0", 4, "orientation"), InputError);
}

// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"

TEST(ModalitySpec, Parses) {
  auto s = ced::modality_spec::parse(" bands(nir, red_edge):0.15,range=0..255,norm=l2 ");
  EXPECT_EQ(s.name(), "bands");
  EXPECT_EQ(s.args(), (std::vector<std::string>{"nir", "red_edge"}));
  EXPECT_DOUBLE_EQ(s.threshold_or(0), 0.15);
  EXPECT_EQ(s.take("range").value(), "0..255");
  EXPECT_EQ(s.take("norm").value(), "l2");
  EXPECT_FALSE(s.take("other"));
  auto t = ced::modality_spec::parse("rgb");
  EXPECT_FALSE(t.threshold());
  EXPECT_DOUBLE_EQ(t.threshold_or(0.1), 0.1);
}

TEST(ModalitySpec, BadSpecsAreClearErrors) {
  auto expect_error = [](const std::string& spec, const std::string& what) {
    try {
      ced::make_modality(spec);
      FAIL() << "no error for " << spec;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << spec << ": " << e.what();
    }
  };
  expect_error("", "empty");
  expect_error("colour:0.1", "unknown modality 'colour'");
  expect_error("rgb:abc", "not a number");
  expect_error("rgb:-0.1", "negative");
  expect_error("rgb:nan", "not a finite number");
  expect_error("rgb:0.1,gamma=2", "no option 'gamma'");
  expect_error("bands(nir", "missing ')'");
  expect_error("bands", "needs field names");
  expect_error("xyz(a)", "takes no field list");
  expect_error("rgb,norm=l3", "norm must be");
  expect_error("bands(a):0.1,range=5..1", "high end");
  expect_error("rgb:0.1,range", "key=value");
  EXPECT_THROW(ced::preset("ced9d"), std::invalid_argument);
}

TEST(ModalitySpec, SplitJoinedSpecsKeepsOptionsAndFieldLists) {
  EXPECT_EQ(ced::split_modality_specs("xyz:0.25,rgb:0.12"), (std::vector<std::string>{"xyz:0.25", "rgb:0.12"}));
  EXPECT_EQ(ced::split_modality_specs("bands(nir,red):0.1,range=0..255,xyz"),
            (std::vector<std::string>{"bands(nir,red):0.1,range=0..255", "xyz"}));
  EXPECT_EQ(ced::split_modality_specs("intensity(a=b):0.1"), (std::vector<std::string>{"intensity(a=b):0.1"}));
  EXPECT_EQ(ced::split_modality_specs(",,xyz,"), (std::vector<std::string>{"xyz"}));
  EXPECT_TRUE(ced::split_modality_specs("").empty());
}

TEST(ModalitySpec, AFieldGivenTwiceIsAnError) {
  // intensity takes its field in parentheses or as field=, not both (#25).
  auto message = [](const std::string& spec) {
    try {
      ced::make_modality(spec);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("intensity(red):0.05,field=green").find("field given twice"), std::string::npos);
  EXPECT_NE(message("intensity(red),field=red").find("field given twice"), std::string::npos);
  EXPECT_NE(message("intensity(a,b)").find("at most one field"), std::string::npos);
  // A field list names each field once (any case: fields are found ignoring it).
  EXPECT_NE(message("bands(nir,red,nir):0.1").find("'nir' twice"), std::string::npos);
  EXPECT_NE(message("bands(NIR,nir)").find("twice"), std::string::npos);
  EXPECT_NE(message("bands(nir):0.1,field=red").find("no option 'field'"), std::string::npos);
  // One way or the other is fine.
  EXPECT_EQ(ced::make_modality("intensity(red):0.05").name(), "intensity(red)");
  EXPECT_EQ(ced::make_modality("intensity:0.05,field=red").name(), "intensity(red)");
  EXPECT_EQ(ced::make_modality("bands(nir,red)").fields()->size(), 2u);
}

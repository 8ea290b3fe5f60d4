// A GoogleTest fixture base for tests that bake on the GPU: one
// AtlasRenderer per test suite (creating a Vulkan device per test would
// dominate their run time), available to the suite's tests as renderer_.
#ifndef IMPOSTOR_TESTS_GPU_SHARED_RENDERER_TEST_H_
#define IMPOSTOR_TESTS_GPU_SHARED_RENDERER_TEST_H_

#include <memory>

#include <gtest/gtest.h>

#include "worker/gpu/atlas_renderer.h"

namespace impostor::testing {

class SharedRendererTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto r = AtlasRenderer::Create();
    ASSERT_TRUE(r.ok()) << r.status();
    renderer_ = std::move(*r).release();
  }
  static void TearDownTestSuite() {
    delete renderer_;
    renderer_ = nullptr;
  }
  static inline AtlasRenderer* renderer_ = nullptr;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_GPU_SHARED_RENDERER_TEST_H_

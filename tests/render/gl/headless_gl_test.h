// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A test suite's headless OpenGL 3.3 context (EGL surfaceless, Mesa llvmpipe
// without a GPU): made once per suite, current before each test, and no GL
// error may be left after one.

#include <gtest/gtest.h>

#include <epoxy/gl.h>

#include <cstdlib>

#include "render/gl/gl_context.h"

namespace cityatlas::render {

class HeadlessGlTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        // The tests must not depend on a display: EGL surfaceless only.
        unsetenv("DISPLAY");
        unsetenv("WAYLAND_DISPLAY");
        Status status;
        context_ = HeadlessContext::create(&status).release();
        ASSERT_NE(context_, nullptr) << status.error;
        ASSERT_TRUE(status.ok());
    }
    static void TearDownTestSuite() {
        delete context_;
        context_ = nullptr;
    }
    void SetUp() override {
        ASSERT_NE(context_, nullptr);
        ASSERT_TRUE(context_->makeCurrent());
    }
    void TearDown() override { EXPECT_EQ(glGetError(), static_cast<GLenum>(GL_NO_ERROR)); }

    static inline HeadlessContext* context_ = nullptr;
};

}  // namespace cityatlas::render

// The built-in body's realtime skin at one LOD, with or without contact: the body the skin tests
// pose. A body that fails to build fails the test and comes back null.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "mimic/avatar/body_model.h"
#include "mimic/avatar/realtime_skin.h"

namespace mimic::test {

inline std::shared_ptr<const avatar::RealtimeBody> built_in_realtime_body(int lod = 0, bool contact = true) {
  avatar::RealtimeOptions o;
  o.lod = lod;
  o.contact = contact;
  auto b = avatar::RealtimeBody::create(avatar::default_body_model(), o);
  EXPECT_TRUE(b) << b.error().what();
  return b ? *b : nullptr;
}

}  // namespace mimic::test

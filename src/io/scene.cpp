#include "amhmvs_mapping/io/scene.h"

namespace amhmvs {

int Scene::indexOf(int view_id) const {
  for (size_t i = 0; i < views.size(); ++i) {
    if (views[i].id == view_id) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace amhmvs

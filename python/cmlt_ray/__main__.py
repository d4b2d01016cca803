"""``python -m cmlt_ray render SCENE --parts N ...``"""

import sys

from .driver import main

sys.exit(main())

"""placeholder"""


def run(target, kind):
    return []

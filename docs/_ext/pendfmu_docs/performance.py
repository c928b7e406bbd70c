"""stub"""


def markdown(app=None) -> str:
    return ""
